"""Objectives a verification study's c5 converges under, and what each costs in certainty (by hand).

For one case folder of ``indent-studio verification-study`` (``L<k>-s1.npz``, the finest level
solved with sensitivities and taken as the model), each objective below fits every coarser level's
noise-free response (one Gauss-Newton step in log theta, as
``inference.budgets.study_quantities.parameter_bias``) and the c5 sequence over the levels gives the
observed orders, the asymptotic test and the GCI (``forward.convergence.gci.study_quantity``);
beside it the 95 % half-width of eq. 6 to 8 that a typical experiment gives with that objective
(2 % force noise per step, 0.02 mm DIC noise at every measured node, as
``inference.budgets.error_budget`` computes it). An objective is the paper's (eq. 4, 5, Appendix B) with:

- ``paper``: the weights (0.45, 0.35, 0.2, 0), the top nodes within 25 mm, those under the sphere
  (r < R) obscured;
- ``rings >= k R``: the nodes under k R left out as well (1.2 R is where the authors' code's ring
  of data starts, ``design.nodal_weights.default_selection(reading="authors")``);
- ``with uz``: weights (0.45, 0.2, 0.15, 0.2);
- ``fov F``: the nodes within F mm.

    .venv/bin/python benchmarks/probes/objective_options.py runs/verification/core13-R8/R8/c1-11_c5-330
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from indentation_studio.design.certainty import bounds_pct, s_from_data
from indentation_studio.design.objective import PAPER_WEIGHTS, Objective
from indentation_studio.forward.convergence.gci import study_quantity
from indentation_studio.forward.convergence.mesh_family import MeshFamily
from indentation_studio.forward.predictor import Prediction
from indentation_studio.forward.result import SimulationResult
from indentation_studio.inference.budgets.error_budget import noise_objective_value
from indentation_studio.inference.budgets.mesh_check import prediction_at_nodes

FORCE_NOISE = 0.02
DIC_NOISE_MM = 0.02

#: name: (weights, field of view in mm, inner rings left out in R)
OPTIONS = {
    "paper": (PAPER_WEIGHTS, 25.0, 1.0),
    "rings >= 1.2 R": (PAPER_WEIGHTS, 25.0, 1.2),  # the inner edge of the authors' code's ring
    "rings >= 1.5 R": (PAPER_WEIGHTS, 25.0, 1.5),
    "rings >= 2 R": (PAPER_WEIGHTS, 25.0, 2.0),
    "with uz": ((0.45, 0.2, 0.15, 0.2), 25.0, 1.0),
    "fov 40": (PAPER_WEIGHTS, 40.0, 1.0),
    "fov 40, rings >= 2 R": (PAPER_WEIGHTS, 40.0, 2.0),
}


def fit_c5(model: SimulationResult, pred: Prediction, target: Prediction, weights, fov: float, inner: float):
    """(c5 fitted to ``target`` by one Gauss-Newton step, the noise-only 95 % half-widths in %)."""
    theta = np.array([model.spec["material"]["c1"], model.spec["material"]["c5"]], float)
    top = np.asarray(model.top_xyz)
    radius = float(model.spec["indenter"]["radius"])
    r = np.hypot(top[:, 0], top[:, 1])
    objective = Objective(
        target.force[0], target.displacement[0], top, radius, mask=(r <= fov) & (r >= inner * radius)
    )
    res = objective.residuals(pred, weights)[0]
    J = objective.jacobian(pred, weights)[0] * theta
    delta, *_ = np.linalg.lstsq(J, -res, rcond=None)
    s = s_from_data(
        noise_objective_value(objective, weights, FORCE_NOISE, DIC_NOISE_MM), objective.data_points(weights)
    )
    return float(theta[1] * np.exp(delta[1])), bounds_pct(2.0 * J.T @ J, s)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("case", type=Path, help="a case folder of a verification study")
    args = ap.parse_args()
    levels = sorted(int(p.name[1 : p.name.index("-")]) for p in args.case.glob("L*-s1.npz"))
    runs = {k: SimulationResult.load(args.case / f"L{k}-s1.npz") for k in levels}
    model = runs[levels[-1]]
    family = MeshFamily(**{k: v for k, v in _family_of(args.case).items() if k != "name"})
    sizes = [family.size(k) for k in levels[::-1]]  # finest first
    pred = Prediction.from_results([model], ("c1", "c5"))
    targets = {k: prediction_at_nodes(run, model.top_xyz) for k, run in runs.items()}
    c5 = model.spec["material"]["c5"]
    print(f"{args.case}: c5 from {c5:g} kPa, level {levels[-1]} the model")
    print("| objective | fit c5 on levels " + ", ".join(str(k) for k in levels[::-1]) + " | orders | asymptotic "
          "| GCI of c5: the model, the next level | noise-only half-width c1, c5 |")  # fmt: skip
    print("| --- | --- | --- | --- | --- | --- |")
    for name, (weights, fov, inner) in OPTIONS.items():
        fits = [fit_c5(model, pred, targets[k], weights, fov, inner) for k in levels[::-1]]
        values = [f for f, _ in fits]
        half = fits[0][1]
        q = study_quantity(name, values, sizes)
        print(
            f"| {name} | " + ", ".join(f"{v:.1f}" for v in values) + " | "
            + ", ".join(f"{p:.2f}" for p in q.orders) + f" | {'yes' if q.asymptotic else 'no'} | "
            f"{q.gci_pct[0]:.2f} %, {q.gci_pct[1]:.2f} % | {half[0]:.2f} %, {half[1]:.2f} % |"
        )  # fmt: skip


def _family_of(case: Path) -> dict:
    """The mesh family of the study a case folder belongs to (its study.json, two folders up)."""
    return json.loads((case.parent.parent / "study.json").read_text())["family"]


if __name__ == "__main__":
    main()
