"""A Krylov solve of a Newton step preconditioned with a factorisation (docs/architecture.md,
"forward"): CG for the stick's symmetric tangent, restarted GMRES for friction's unsymmetric one,
the constrained dofs eliminated, every operator's application counted in the run's statistics.
:meth:`forward.linear_steps.LinearSteps.krylov` decides when it runs and what its result is worth.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = ["krylov_solve"]


def krylov_solve(
    K: sp.csr_matrix,
    cmask: np.ndarray,
    rhs: np.ndarray,
    precondition: Callable[[np.ndarray], np.ndarray],
    *,
    symmetric: bool,
    rtol: float,
    maxiter: int,
    cycles: int = 1,
    stats: dict,
) -> tuple[np.ndarray, int, bool]:
    """Solve K x = rhs, the dofs in ``cmask`` held at 0, by scipy's CG or GMRES.

    Parameters
    ----------
    K : scipy.sparse.csr_matrix
        The tangent.
    cmask : ndarray of bool, shape (3n,)
        The dofs held (the operator is the identity on them).
    rhs : ndarray, shape (3n,)
        The right-hand side.
    precondition : callable
        The preconditioner applied to a residual (the factorisation in hand and the contact's
        correction).
    symmetric : bool
        CG where True, else GMRES restarted every ``maxiter`` iterations.
    rtol : float
        Relative residual to reach.
    maxiter : int
        Iterations at most (CG); with GMRES, iterations a cycle.
    cycles : int, optional
        GMRES's cycles at most.
    stats : dict
        The run's counters: ``krylov_matvecs``, ``krylov_matvec_s``,
        ``preconditioner_applications`` and ``preconditioner_s`` are added to.

    Returns
    -------
    x : ndarray, shape (3n,)
        The last iterate (its held dofs as the solver left them).
    iterations : int
        Krylov iterations made.
    converged : bool
        Whether ``rtol`` was reached with a finite iterate.
    """

    def matvec(x: np.ndarray) -> np.ndarray:
        t_mv = time.perf_counter()
        y = K @ np.where(cmask, 0.0, x)
        y[cmask] = x[cmask]
        stats["krylov_matvecs"] += 1
        stats["krylov_matvec_s"] += time.perf_counter() - t_mv
        return y

    def preconditioner(r: np.ndarray) -> np.ndarray:
        t_pc = time.perf_counter()
        y = precondition(r)
        stats["preconditioner_applications"] += 1
        stats["preconditioner_s"] += time.perf_counter() - t_pc
        return y

    n = rhs.size
    A = spla.LinearOperator((n, n), matvec=matvec, dtype=float)
    M = spla.LinearOperator((n, n), matvec=preconditioner, dtype=float)
    its = [0]

    def count(_x: np.ndarray) -> None:
        its[0] += 1

    if symmetric:
        x, info = spla.cg(A, rhs, rtol=rtol, maxiter=maxiter, M=M, callback=count)
    else:
        x, info = spla.gmres(
            A, rhs, rtol=rtol, restart=maxiter, maxiter=cycles, M=M, callback=count, callback_type="pr_norm"
        )
    return x, its[0], info == 0 and bool(np.all(np.isfinite(x)))
