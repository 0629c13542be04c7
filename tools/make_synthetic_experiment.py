"""Write a synthetic experiment (by hand; see README "Experiments") made on a finer mesh than the fit uses.

    .venv/bin/python tools/make_synthetic_experiment.py --c1 12 --c5 250 --noise 0.02 --mesh fine --out runs/exp-12-250

The paper protocol (R, 28 x 0.5 mm) on the ``--mesh`` preset; DIC-like points over a 25 mm field
of view with the indenter's shadow removed, ``--noise`` x max |u| per direction on the
displacements and ``--noise`` x f on the force readings, fibers at 60 degrees in the DIC frame.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np

from indentation_studio.forward.fe_predictor import FESolverPredictor
from indentation_studio.forward.result import SimulationResult
from indentation_studio.forward.spec import Indenter, MeshChoice, ModelSpec
from indentation_studio.inference.experiment.synthetic import (
    LAB_RECORDING,
    Recording,
    write_experiment_from_model,
    write_synthetic_experiment,
)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--c1", type=float, default=12.0)
    ap.add_argument("--c5", type=float, default=250.0)
    ap.add_argument("--radius", type=float, default=4.77)
    ap.add_argument("--noise", type=float, default=0.02)
    ap.add_argument("--mesh", default="fine")
    ap.add_argument("--fiber-angle", type=float, default=60.0)
    ap.add_argument("--unknown-fibers", action="store_true", help="write fiber_angle_deg = null")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--points", type=int, default=6000, help="DIC points over the field of view")
    ap.add_argument("--out", default="runs/exp-12-250")
    ap.add_argument(
        "--lab",
        action="store_true",
        help="--from-run: record as a lab would (LAB_RECORDING: 0.02 mm DIC noise, 2 %% force noise, the "
        "indentation point 0.1 mm off, 6000 points), --noise and --points ignored",
    )
    ap.add_argument("--misregistration", type=float, help="--lab: the indentation point this far off, mm")
    ap.add_argument(
        "--from-run",
        help="a stored simulation (.npz of indent-studio simulate) at --c1, --c5, --radius to record instead "
        "of solving (e.g. a contact-L4 run of 20 to 45 minutes)",
    )
    args = ap.parse_args()
    spec = ModelSpec(indenter=Indenter(args.radius), mesh=MeshChoice(args.mesh))
    t0 = time.perf_counter()
    if args.from_run:
        path = _from_run(args)
        print(f"wrote {path} (recorded from {args.from_run})")
        return
    path = write_synthetic_experiment(
        FESolverPredictor(spec),
        np.array([args.c1, args.c5]),
        args.out,
        radius=args.radius,
        step_size=spec.protocol.step_size,
        u_noise=args.noise,
        f_noise=args.noise,
        fiber_angle_deg=args.fiber_angle,
        write_fiber_angle=not args.unknown_fibers,
        seed=args.seed,
        points=args.points,
    )
    print(f"wrote {path} ({args.mesh} mesh, {time.perf_counter() - t0:.0f} s)")


def _from_run(args) -> object:
    """The experiment recorded from a stored run, after checking it is the run asked for."""
    run = SimulationResult.load(args.from_run)
    material, radius = run.spec["material"], run.spec["indenter"]["radius"]
    if not np.allclose([material["c1"], material["c5"], radius], [args.c1, args.c5, args.radius]):
        raise SystemExit(
            f"{args.from_run}: c1 {material['c1']}, c5 {material['c5']}, R {radius}, not the asked "
            f"{args.c1}, {args.c5}, {args.radius}"
        )
    recording = Recording(
        u_noise=args.noise,
        f_noise=args.noise,
        points=args.points,
        fiber_angle_deg=args.fiber_angle,
        write_fiber_angle=not args.unknown_fibers,
    )
    if args.lab:
        recording = replace(
            LAB_RECORDING, fiber_angle_deg=args.fiber_angle, write_fiber_angle=not args.unknown_fibers
        )
        if args.misregistration is not None:
            recording = replace(recording, misregistration_mm=args.misregistration)
    friction = (run.spec.get("contact") or {}).get("friction")
    steps = np.asarray(run.depth) > 0  # a run's first row is depth 0
    return write_experiment_from_model(
        run.force[steps],
        run.displacement[steps],
        run.top_xyz,
        args.out,
        radius=args.radius,
        step_size=run.spec["protocol"]["step_size"],
        truth=[args.c1, args.c5] if friction is None else [args.c1, args.c5, friction],
        model=run.spec,
        recording=recording,
        seed=args.seed,
    )


if __name__ == "__main__":
    main()
