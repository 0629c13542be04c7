"""Benchmark (by hand): the worn-factorisation rule against never worn (docs/validation/
solver-and-speed.md, "Refactorising a worn factorisation"; issue 58).

Runs one case on one thread twice, with ``WORN_KRYLOV`` as shipped and infinite (a factorisation
is then kept until a Krylov solve on it fails), and prints each run's CPU seconds and counts
(Newton iterations, factorisations, Krylov calls, failures and iterations) and the largest
relative force difference between them. With ``--tight`` also a run to ``residual_tol`` 1e-8 (the
rule off), and each run's distance from it: how far Newton's own tolerance lets a run land.

    .venv/bin/python benchmarks/probes/worn_factorisation.py --mesh contact-L2 --c1 19 --c5 120 --tight
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the profile's cases
import solver_profile

from indentation_studio.forward import linear_steps
from indentation_studio.forward.solver import EmbeddedSolver
from indentation_studio.forward.spec import ModelSpec


def _run(spec: ModelSpec, worn: float) -> tuple[np.ndarray, str]:
    """One run with ``WORN_KRYLOV = worn``: its forces and a line of counts."""
    shipped = linear_steps.WORN_KRYLOV
    linear_steps.WORN_KRYLOV = worn
    try:
        t = time.process_time()
        r = EmbeddedSolver(spec).run(threads=1)
        cpu = time.process_time() - t
    finally:
        linear_steps.WORN_KRYLOV = shipped
    st = r.solver["stats"]
    line = (
        f"WORN_KRYLOV {worn:g}: CPU {cpu:.1f} s, Newton {int(np.sum(r.convergence['newton_iterations']))}, "
        f"factorisations {st['factorizations']}, Krylov calls {st['krylov_calls']}, "
        f"failed {st['krylov_failures']}, iterations {st['krylov_iterations']}"
    )
    return r.force, line


def _largest_relative(a: np.ndarray, b: np.ndarray) -> float:
    """The largest relative difference of two force histories past their first (zero) step."""
    return float(np.max(np.abs(a[1:] - b[1:]) / np.abs(b[1:])))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mesh", default="contact-L1")
    ap.add_argument("--radius", type=float, default=4.77)
    ap.add_argument("--c1", type=float, default=10.0)
    ap.add_argument("--c5", type=float, default=350.0)
    ap.add_argument("--mu", type=float, default=None)
    ap.add_argument("--steps", type=int, default=28)
    ap.add_argument("--tight", action="store_true", help="also a run to residual_tol 1e-8")
    args = ap.parse_args()
    case = {"mesh": args.mesh, "radius": args.radius, "c1": args.c1, "c5": args.c5, "friction": args.mu}
    spec = solver_profile.case_spec(case, args.steps)
    with_rule, line = _run(spec, linear_steps.WORN_KRYLOV)
    print(line)
    never, line = _run(spec, np.inf)
    print(line)
    print(f"forces: largest relative difference {_largest_relative(with_rule, never):.1e}")
    if args.tight:
        tight_spec = dataclasses.replace(spec, solver=dataclasses.replace(spec.solver, residual_tol=1e-8))
        tight, _ = _run(tight_spec, np.inf)
        print(
            f"against residual_tol 1e-8: with the rule {_largest_relative(with_rule, tight):.1e}, "
            f"never worn {_largest_relative(never, tight):.1e}"
        )


if __name__ == "__main__":
    main()
