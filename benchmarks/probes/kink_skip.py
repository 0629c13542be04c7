"""Benchmark (by hand): friction's Newton steps across the fibers' kink factorise at once
(``forward.linear_steps.KINK_CROSSINGS``, on meshes of at least ``KINK_DOFS`` dofs) against the
rule off (docs/validation/solver-and-speed.md, "Skipping the Krylov try across the fibers' kink";
issue 58). One thread, no sensitivities; the forces of each run are saved to ``--save`` and
compared with ``--against`` (another run's file).

    .venv/bin/python benchmarks/probes/kink_skip.py MESH R C1 C5 MU STEPS --save rule.npy
    .venv/bin/python benchmarks/probes/kink_skip.py MESH R C1 C5 MU STEPS --off --save off.npy --against rule.npy
    ... --residual-tol 1e-8   (Newton to a tighter tolerance, to place the two runs)
"""

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

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
for name, kind in (
    ("mesh", str),
    ("radius", float),
    ("c1", float),
    ("c5", float),
    ("mu", float),
    ("steps", int),
):
    ap.add_argument(name, type=kind)
ap.add_argument("--off", action="store_true", help="the kink rule off (KINK_DOFS infinite)")
ap.add_argument(
    "--residual-tol", type=float, help="Newton's relative residual (the spec's default if absent)"
)
ap.add_argument("--save", required=True)
ap.add_argument("--against")
args = ap.parse_args()
case = {"mesh": args.mesh, "radius": args.radius, "c1": args.c1, "c5": args.c5, "friction": args.mu or None}
spec = solver_profile.case_spec(case, args.steps)
if args.residual_tol:
    spec = dataclasses.replace(spec, solver=dataclasses.replace(spec.solver, residual_tol=args.residual_tol))
if args.off:
    linear_steps.KINK_DOFS = np.inf
t = time.process_time()
r = EmbeddedSolver(spec).run(threads=1)
cpu = time.process_time() - t
st = r.solver["stats"]
np.save(args.save, r.force)
line = (
    f"{'off' if args.off else 'rule'} {args.mesh} R {args.radius} {{{args.c1}, {args.c5}}} mu {args.mu} "
    f"{args.steps} steps: CPU {cpu:.1f} s, Newton {int(np.sum(r.convergence['newton_iterations']))}, "
    f"factorisations {st['factorizations']}, Krylov failures {st['krylov_failures']}, Krylov iterations "
    f"{st['krylov_iterations']}, kink refactorisations {st['kink_refactorisations']}"
)
if args.against:
    other = np.load(args.against)
    line += f"; forces against {args.against}: {np.max(np.abs(r.force[1:] / other[1:] - 1)):.1e}"
print(line)
