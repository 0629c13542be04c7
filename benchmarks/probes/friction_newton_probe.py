"""Benchmark (by hand): where a frictional run's steps go, Newton iteration by Newton iteration
(docs/validation/friction.md, "Limits and cost").

Runs the first ``--steps`` steps of the paper protocol on ``--mesh`` with ``--mu`` (or the stick) at
R = ``--radius``, one thread, and prints per step the wall time, the Newton iterations and the linear
solver's counts; with ``--iterations`` also each Newton iteration's residual and the fraction of the
step the anchor cut left (``FrictionContactState.step_fraction``: no slipping contact point is taken
past its anchor).

    .venv/bin/python benchmarks/probes/friction_newton_probe.py --mesh contact-L3 --steps 2 --mu 0.3 --iterations
"""

from __future__ import annotations

import argparse
import json
import logging
import time

from indentation_studio.forward import coulomb_contact
from indentation_studio.forward.solver import EmbeddedSolver
from indentation_studio.forward.spec import Indenter, MeshChoice, ModelSpec, Protocol


def _log_step_fractions() -> None:
    """Log each anchor cut (the fraction and the points slipping) at DEBUG, as the solve asks for it."""
    original = coulomb_contact.FrictionContactState.step_fraction
    say = logging.getLogger("probe")

    def logged(self, u_top, step_top, depth):
        fraction = original(self, u_top, step_top, depth)
        slipping = int(self.response(u_top, depth).slipping.sum())
        say.debug("  anchor cut: fraction %.3g of the step (%d points slipping)", fraction, slipping)
        return fraction

    coulomb_contact.FrictionContactState.step_fraction = logged


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mesh", default="contact-L3")
    ap.add_argument("--steps", type=int, default=2)
    ap.add_argument("--mu", default="0.3", help="Coulomb's mu, or 'stick'")
    ap.add_argument("--radius", type=float, default=8.0)
    ap.add_argument("--c1", type=float, default=7.0)
    ap.add_argument("--c5", type=float, default=520.0)
    ap.add_argument("--iterations", action="store_true", help="each Newton iteration and anchor cut")
    args = ap.parse_args()
    if args.iterations:
        logging.basicConfig(level=logging.WARNING, format="%(message)s")
        for name in ("indentation_studio.forward.penalty_contact", "probe"):
            logging.getLogger(name).setLevel(logging.DEBUG)
        _log_step_fractions()
    spec = ModelSpec(
        mesh=MeshChoice(args.mesh),
        indenter=Indenter(args.radius),
        protocol=Protocol(step_size=0.5, steps=args.steps),
    ).with_material(c1=args.c1, c5=args.c5)
    if args.mu != "stick":
        spec = spec.with_friction(float(args.mu))
    solver = EmbeddedSolver(spec)
    t0, before = time.perf_counter(), dict(solver.stats)

    def progress(step: int, steps: int, force: float) -> None:
        nonlocal before
        now = dict(solver.stats)
        change = {k: round(now[k] - before[k], 1) for k in ("factorizations", "krylov_iterations", "solve_s")}
        print(
            f"step {step}/{steps}: {time.perf_counter() - t0:.1f} s so far; {json.dumps(change)}", flush=True
        )
        before = now

    result = solver.run(progress=progress, threads=1)
    c = result.convergence
    print(
        json.dumps(
            {
                "mesh": args.mesh,
                "dofs": solver.n_dofs,
                "mu": args.mu,
                "newton_iterations": [int(v) for v in c["newton_iterations"]],
                "step_wall_s": [round(float(v), 1) for v in c["wall_s"]],
            }
        )
    )


if __name__ == "__main__":
    main()
