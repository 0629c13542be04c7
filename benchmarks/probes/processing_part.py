"""The processing's part of a fit's bounds against the shift it stands for (issue 45).

For each case: a noise-free synthetic experiment made by the FE model itself (so that only the
processing can move a fit: the DIC points taken to the nodes, and the registration when the
indenter's points are misplaced), its fit on the same FE model from the truth, and the part that
``inference.experiment.processing_error`` measures at the truth. Prints one row per case: the fit's shift
from the truth and the part (the planes' signed shift, the registration part, the total).

    .venv/bin/python benchmarks/probes/processing_part.py --mesh contact-L1 --steps 28 \\
        --cases 4.77:12:250,8:4:200 --misregistration 0,0.1
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from indentation_studio.design.objective import PAPER_WEIGHTS
from indentation_studio.forward.fe_predictor import FESolverPredictor
from indentation_studio.forward.spec import Indenter, MeshChoice, ModelSpec, Protocol
from indentation_studio.inference.experiment.data import load_experiment
from indentation_studio.inference.experiment.processing import experiment_objective
from indentation_studio.inference.experiment.processing_error import processing_error_at
from indentation_studio.inference.experiment.synthetic import write_synthetic_experiment
from indentation_studio.inference.fit.inverse_fit import fit_parameters


def one_case(
    mesh: str, steps: int, radius: float, theta: np.ndarray, misregistration: float, points: int
) -> dict:
    """The fit's shift and the part at one case (noise-free, the FE model's own data)."""
    spec = ModelSpec(
        mesh=MeshChoice(mesh), indenter=Indenter(radius), protocol=Protocol(step_size=0.5, steps=steps)
    )
    fe = FESolverPredictor(spec, sensitivities=True)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        folder = write_synthetic_experiment(
            fe,
            theta,
            Path(tmp) / "exp",
            radius=radius,
            step_size=0.5,
            points=points,
            u_noise=0.0,
            f_noise=0.0,
            misregistration_mm=misregistration,
        )
        exp = load_experiment(folder)
    objective, dic = experiment_objective(exp, fe.predict(theta[None]).top_xyz)
    part = processing_error_at(objective, dic, fe, theta, PAPER_WEIGHTS, used_steps=exp.used_steps)
    fit = fit_parameters(objective, fe, PAPER_WEIGHTS, theta0=theta)
    shift = 100.0 * (fit.theta / theta - 1.0)
    return {
        "mesh": mesh,
        "steps": steps,
        "radius": radius,
        "theta": theta.tolist(),
        "misregistration_mm": misregistration,
        "fit_shift_pct": shift.tolist(),
        "interpolation_shift_pct": part.interpolation_shift_pct.tolist(),
        "registration_pct": part.registration_pct.tolist(),
        "processing_pct": part.half_width_pct.tolist(),
        "inside": bool(np.all(np.abs(shift) <= part.half_width_pct)),
        "wall_s": time.perf_counter() - t0,
    }


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--mesh", default="contact-L1")
    parser.add_argument("--steps", type=int, default=28)
    parser.add_argument("--cases", default="4.77:12:250", help="R:c1:c5, comma-separated")
    parser.add_argument("--misregistration", default="0,0.1", help="mm, comma-separated")
    parser.add_argument("--points", type=int, default=6000, help="DIC points over the 25 mm field of view")
    parser.add_argument("--out", type=Path, help="write the rows as JSON")
    args = parser.parse_args()
    rows = []
    for case in args.cases.split(","):
        radius, c1, c5 = (float(v) for v in case.split(":"))
        for mis in (float(v) for v in args.misregistration.split(",")):
            row = one_case(args.mesh, args.steps, radius, np.array([c1, c5]), mis, args.points)
            rows.append(row)
            s, i, r, p = (
                np.round(row[k], 3).tolist()
                for k in ("fit_shift_pct", "interpolation_shift_pct", "registration_pct", "processing_pct")
            )
            print(
                f"R {radius:g}, {{{c1:g}, {c5:g}}}, misregistration {mis:g} mm: fit shift {s} %, planes {i} %, "
                f"registration {r} %, part {p} %, inside {row['inside']} ({row['wall_s']:.0f} s)",
                flush=True,
            )
    if args.out:
        args.out.write_text(
            json.dumps({"command": vars(args) | {"out": str(args.out)}, "rows": rows}, indent=1)
        )


if __name__ == "__main__":
    main()
