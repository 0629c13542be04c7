"""Benchmark (by hand): an algebraic multigrid preconditioner for CG against the solver's PARDISO
factorisation, on a real tangent of the fine levels (issue 58, deliverable 2).

The solver's tangent and right-hand side are taken at its ``--capture``-th fresh Newton step (the
step that factorises) of a run on ``--mesh``; then, on that system with the supports and symmetry
planes eliminated:

* PARDISO as the solver uses it (``ConstrainedSymmetricSolver``; single precision from
  ``forward.solver.SINGLE_PRECISION_DOFS`` dofs): the factorisation, one back-substitution, and
  CG preconditioned with it to the Newton step's tolerance (``KRYLOV_RTOL``) and the sensitivity
  solve's (``SENSITIVITY_RTOL``);
* pyamg's smoothed aggregation (3 x 3 blocks, the six rigid-body modes as its near-null space):
  its set-up, one V-cycle, and CG preconditioned with it to the same tolerances.

pyamg comes with the ``bench`` extra (``pip install -e ".[bench]"``), not with the package. One thread.

    .venv/bin/python benchmarks/amg_preconditioner.py --mesh contact-L3 --c1 10 --c5 350 --capture 3
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

try:
    import pyamg
except ImportError as exc:  # not a dependency of the package
    raise SystemExit('this benchmark needs pyamg: .venv/bin/pip install -e ".[bench]"') from exc

sys.path.insert(0, str(Path(__file__).resolve().parent))
import solver_profile

from indentation_studio.forward import linear_steps, sensitivity_solves
from indentation_studio.forward.solver import EmbeddedSolver


class Captured(Exception):
    """Raised inside the run once the system is taken."""


def capture_system(spec, which: int) -> tuple[EmbeddedSolver, sp.csr_matrix, np.ndarray, np.ndarray]:
    """The tangent, held dofs and right-hand side of the run's ``which``-th fresh Newton step."""
    solver = EmbeddedSolver(spec)
    calls = [0]
    taken: dict = {}
    real = solver.fresh_step

    def fresh_step(K, cmask, rhs):
        calls[0] += 1
        if calls[0] == which:
            taken.update(K=K.copy(), cmask=cmask.copy(), rhs=rhs.copy())
            raise Captured
        return real(K, cmask, rhs)

    solver.fresh_step = fresh_step
    try:
        solver.run(threads=1)
    except Captured:
        pass
    if not taken:
        raise SystemExit(f"the run made fewer than {which} fresh Newton steps")
    return solver, taken["K"], taken["cmask"], taken["rhs"]


def rigid_body_modes(xyz: np.ndarray) -> np.ndarray:
    """The six rigid-body modes of 3D elasticity at the nodes, (3n, 6)."""
    n = xyz.shape[0]
    B = np.zeros((n, 3, 6))
    for k in range(3):
        B[:, k, k] = 1.0
    x, y, z = (xyz - xyz.mean(axis=0)).T
    B[:, 0, 3], B[:, 1, 3] = -y, x  # about z
    B[:, 1, 4], B[:, 2, 4] = -z, y  # about x
    B[:, 0, 5], B[:, 2, 5] = z, -x  # about y
    return B.reshape(3 * n, 6)


def cg_run(A, b, M, rtol: float, maxiter: int = 2000) -> tuple[int, float, bool]:
    its = [0]

    def count(_x):
        its[0] += 1

    t = time.perf_counter()
    x, info = spla.cg(A, b, rtol=rtol, maxiter=maxiter, M=M, callback=count)
    dt = time.perf_counter() - t
    rel = float(np.linalg.norm(b - A @ x) / np.linalg.norm(b))
    return its[0], dt, info == 0 and rel <= rtol * 1.0001


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mesh", default="contact-L3")
    ap.add_argument("--radius", type=float, default=4.77)
    ap.add_argument("--c1", type=float, default=10.0)
    ap.add_argument("--c5", type=float, default=350.0)
    ap.add_argument("--capture", type=int, default=3, help="which fresh Newton step's system")
    ap.add_argument("--steps", type=int, default=28)
    ap.add_argument("--json", type=Path, help="write the figures here")
    args = ap.parse_args()

    case = {
        "mesh": args.mesh,
        "radius": args.radius,
        "c1": args.c1,
        "c5": args.c5,
        "friction": None,
        "sens": False,
    }
    spec = solver_profile.case_spec(case, args.steps)
    t = time.perf_counter()
    solver, K, cmask, rhs = capture_system(spec, args.capture)
    print(
        f"{args.mesh}: {solver.n_dofs} dofs, system of fresh step {args.capture} taken in {time.perf_counter() - t:.1f} s"
    )

    # the held dofs as identity rows (keeps the 3 x 3 node blocks for the aggregation)
    keep = (~cmask).astype(float)
    D = sp.diags(keep)
    A = (D @ K @ D + sp.diags(1.0 - keep)).tocsr()
    A = 0.5 * (A + A.T)  # the stick's tangent is symmetric to round-off
    b = np.where(cmask, 0.0, rhs)
    out: dict = {
        "mesh": args.mesh,
        "dofs": int(solver.n_dofs),
        "c1": args.c1,
        "c5": args.c5,
        "capture": args.capture,
    }

    # PARDISO as the solver uses it
    lin = solver.linear
    t = time.perf_counter()
    lin.factorize(K, cmask)
    t_fact = time.perf_counter() - t
    t = time.perf_counter()
    lin.solve_constrained(b, cmask)
    t_back = time.perf_counter() - t
    M_direct = spla.LinearOperator(A.shape, matvec=lambda r: lin.solve_constrained(r, cmask))
    out["pardiso"] = {
        "factorise_s": t_fact,
        "back_substitution_s": t_back,
        "single_precision": bool(lin.single_precision),
    }
    for name, rtol in (
        ("newton", linear_steps.KRYLOV_RTOL),
        ("sensitivity", sensitivity_solves.SENSITIVITY_RTOL),
    ):
        its, dt, ok = cg_run(A, b, M_direct, rtol)
        out["pardiso"][name] = {"rtol": rtol, "cg_iterations": its, "cg_s": dt, "converged": ok}
    print(f"PARDISO: factorise {t_fact:.2f} s, back-substitution {t_back:.3f} s, {out['pardiso']}")

    # pyamg smoothed aggregation
    B = rigid_body_modes(solver.mesh.nodes)
    B[cmask] = 0.0
    Ab = A.tobsr(blocksize=(3, 3))
    for label, kw in (
        ("sa-default", {}),
        ("sa-energy", {"smooth": "energy"}),
    ):
        t = time.perf_counter()
        ml = pyamg.smoothed_aggregation_solver(Ab, B=B, max_coarse=500, **kw)
        t_setup = time.perf_counter() - t
        M = ml.aspreconditioner(cycle="V")
        t = time.perf_counter()
        M.matvec(b)  # the first makes the coarsest level's solver
        t_first = time.perf_counter() - t
        t = time.perf_counter()
        M.matvec(b)
        t_cycle = time.perf_counter() - t
        t_setup += t_first - t_cycle
        rec = {
            "setup_s": t_setup,
            "v_cycle_s": t_cycle,
            "levels": len(ml.levels),
            "operator_complexity": ml.operator_complexity(),
        }
        for name, rtol in (
            ("newton", linear_steps.KRYLOV_RTOL),
            ("sensitivity", sensitivity_solves.SENSITIVITY_RTOL),
        ):
            its, dt, ok = cg_run(A, b, M, rtol)
            rec[name] = {"rtol": rtol, "cg_iterations": its, "cg_s": dt, "converged": ok}
        out[label] = rec
        print(f"pyamg {label}: {rec}")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
