"""Symmetric sparse solves for the Newton iterations, on one sparsity pattern per run.

Constrained dofs (supports, symmetry planes, nodes stuck to the indenter) are eliminated by
zeroing their rows and columns and putting 1 on the diagonal, so the pattern of the matrix never
changes during a run: the fill-reducing ordering and symbolic analysis are done once and every
Newton iteration pays only the numerical factorisation and the solve.

Backends, chosen by measurement on FEBio's baseline mesh (3,751 free dofs) and ``fine``
(28,182), 2-core machine (README, "Solver choices"):

==========  ==========================  =======================
backend     baseline mesh, factor+solve  ``fine``, factor+solve
==========  ==========================  =======================
pardiso     about 22 ms                 about 0.4 s
superlu     about 105 ms                about 8 s
cholespy    about 115 ms                about 10 s
==========  ==========================  =======================

``pardiso`` (MKL PARDISO through pypardiso, symmetric indefinite mode) is the default;
``superlu`` (scipy) is the fallback when MKL is not importable.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .sparse_assembly import SparsePattern


class LinearSolveError(RuntimeError):
    """The stiffness matrix could not be factorised (singular)."""


def default_backend() -> str:
    try:
        import pypardiso  # noqa: F401
    except Exception:  # MKL missing or not loadable
        return "superlu"
    return "pardiso"


class ConstrainedSymmetricSolver:
    """Factorise K with a set of constrained dofs eliminated, then solve for many right-hand sides."""

    def __init__(self, pattern: SparsePattern, backend: str | None = None) -> None:
        self.pattern = pattern
        self.backend = backend or default_backend()
        if self.backend not in ("pardiso", "superlu"):
            raise ValueError(f"unknown linear solver {self.backend!r}; use 'pardiso' or 'superlu'")
        n = pattern.n_dofs
        self._diag_slot = np.empty(n, dtype=np.int64)
        is_diag = pattern.indices == pattern.row
        self._diag_slot[pattern.row[is_diag]] = np.flatnonzero(is_diag)
        upper = pattern.indices >= pattern.row
        self._upper_slots = np.flatnonzero(upper)
        self._upper_indices = pattern.indices[upper]
        self._upper_indptr = np.searchsorted(pattern.row[upper], np.arange(n + 1)).astype(np.int32)
        self._pardiso = None
        self._analysed = False
        self._lu = None
        self._matrix = None

    def factorize(self, K: sp.csr_matrix, constrained: np.ndarray) -> None:
        """Factorise ``K`` (assembled on this pattern) with ``constrained`` (n,) dofs eliminated."""
        data = K.data.copy()
        p = self.pattern
        data[constrained[p.row] | constrained[p.indices]] = 0.0
        data[self._diag_slot[constrained]] = 1.0
        try:
            if self.backend == "pardiso":
                self._factorize_pardiso(data)
            else:
                A = sp.csc_matrix((data, p.indices, p.indptr), shape=K.shape)
                self._lu = spla.splu(
                    A,
                    permc_spec="MMD_AT_PLUS_A",
                    diag_pivot_thresh=0.0,
                    options={"SymmetricMode": True},
                )
        except LinearSolveError:
            raise
        except Exception as exc:  # pypardiso / SuperLU report singularity in their own types
            raise LinearSolveError(f"{self.backend}: {exc}") from exc

    def _factorize_pardiso(self, data: np.ndarray) -> None:
        import pypardiso

        if self._pardiso is None:
            self._pardiso = pypardiso.PyPardisoSolver(mtype=-2)
        A = sp.csr_matrix(
            (data[self._upper_slots], self._upper_indices, self._upper_indptr),
            shape=(self.pattern.n_dofs, self.pattern.n_dofs),
        )
        self._pardiso._check_A(A)
        b = np.zeros((A.shape[0], 1))
        if not self._analysed:
            self._pardiso.set_phase(11)
            self._pardiso._call_pardiso(A, b)
            self._analysed = True
        self._pardiso.set_phase(22)
        self._pardiso._call_pardiso(A, b)
        self._matrix = A

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """Solve with the last factorisation; ``rhs`` (n,) or (n, m), zero at constrained dofs."""
        if self.backend == "pardiso":
            self._pardiso.set_phase(33)
            x = self._pardiso._call_pardiso(self._matrix, np.asfortranarray(rhs.reshape(rhs.shape[0], -1)))
            x = x.reshape(rhs.shape)
        else:
            x = self._lu.solve(rhs)
        if not np.all(np.isfinite(x)):
            raise LinearSolveError(f"{self.backend}: non-finite solution (singular stiffness?)")
        return x

    def release(self) -> None:
        """Free the solver's memory (PARDISO keeps its factors outside Python)."""
        if self._pardiso is not None:
            self._pardiso.free_memory(everything=True)
            self._pardiso = None
            self._analysed = False
