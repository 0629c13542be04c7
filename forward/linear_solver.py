"""Sparse symmetric positive-definite solves for the Newton iterations.

Backends, chosen by measurement (README, "Solver choices"; ``benchmarks/linear_solvers.py``):

* ``cholmod``-like ``cholespy`` (supernodal sparse Cholesky): the default when importable;
* ``superlu``: scipy's SuperLU, always present, used as the fallback;
* ``pardiso``: MKL PARDISO through pypardiso, when installed.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla


class LinearSolveError(RuntimeError):
    """The stiffness matrix could not be factorised (singular or not positive definite)."""


def _superlu(K: sp.csr_matrix, rhs: np.ndarray) -> np.ndarray:
    lu = spla.splu(K.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                   options={"SymmetricMode": True})
    return lu.solve(rhs)


def _cholespy(K: sp.csr_matrix, rhs: np.ndarray) -> np.ndarray:
    import torch
    from cholespy import CholeskySolverD, MatrixType

    coo = K.tocoo()
    solver = CholeskySolverD(
        K.shape[0], torch.from_numpy(coo.row.astype(np.int32)), torch.from_numpy(coo.col.astype(np.int32)),
        torch.from_numpy(coo.data), MatrixType.COO,
    )
    b = torch.from_numpy(np.ascontiguousarray(rhs.reshape(K.shape[0], -1)))
    x = torch.zeros_like(b)
    solver.solve(b, x)
    return x.numpy().reshape(rhs.shape)


def _pardiso(K: sp.csr_matrix, rhs: np.ndarray) -> np.ndarray:
    import pypardiso

    return pypardiso.spsolve(K.tocsr(), rhs)


BACKENDS = {"superlu": _superlu, "cholespy": _cholespy, "pardiso": _pardiso}


def solve(K: sp.csr_matrix, rhs: np.ndarray, backend: str = "superlu") -> np.ndarray:
    """Solve K x = rhs (rhs (n,) or (n, m)); raise :class:`LinearSolveError` on failure."""
    try:
        x = BACKENDS[backend](K, rhs)
    except (RuntimeError, ValueError) as exc:
        raise LinearSolveError(f"{backend}: {exc}") from exc
    if not np.all(np.isfinite(x)):
        raise LinearSolveError(f"{backend}: non-finite solution (singular stiffness?)")
    return x
