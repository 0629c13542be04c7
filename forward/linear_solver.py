"""Sparse solves for the Newton iterations, on one sparsity pattern per run: symmetric matrices
(the body and the stick contact; with Coulomb friction the tangent's symmetric part, its
unsymmetric slip blocks put back by :class:`LowRankUpdate`).

Constrained dofs (supports, symmetry planes, nodes stuck to the indenter) are eliminated by
zeroing their rows and columns and putting 1 on the diagonal, so the pattern of the matrix never
changes during a run: the fill-reducing ordering and symbolic analysis are done once and every
Newton iteration pays only the numerical factorisation and the solve.

Backends (timings in the README, "Solver choices"): ``pardiso`` (MKL PARDISO through pypardiso,
symmetric indefinite mode) is the default;
``superlu`` (scipy) is the fallback when MKL is not importable.

A factorisation also serves systems with more dofs constrained than it was made with (nodes that
came into contact since): :meth:`ConstrainedSymmetricSolver.solve_constrained` holds the extra
dofs C at zero exactly, through the Schur complement of the factorised matrix A on them,

    y = A^-1 r - W S^-1 (A^-1 r)_C,   W = A^-1 E_C,   S = E_C^T W,

with W computed once per extra dof (one multi-right-hand-side back-substitution for all new
ones), so a contact set that grows costs a few back-substitutions instead of a factorisation.
"""

from __future__ import annotations

import os
import time

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .sparse_assembly import SparsePattern


class LowRankUpdate:
    """The inverse of a factorised matrix A changed on a few dofs, A + E D E^T (E's columns pick
    ``dofs``, D (k, k) any change there, symmetric or not), by the Sherman-Morrison-Woodbury
    identity:

        (A + E D E^T)^-1 r = y - W D S^-1 y_E,   y = A^-1 r,  W = A^-1 E,  S = I + W_E D,

    W from :meth:`ConstrainedSymmetricSolver.inverse_columns` (kept per factorisation), S
    factorised once here; each application then costs a k x k solve and an n x k product."""

    def __init__(self, solver: ConstrainedSymmetricSolver, dofs: np.ndarray, D: np.ndarray) -> None:
        self.dofs = np.asarray(dofs, dtype=np.int64)
        self.D = np.asarray(D, dtype=float)
        self.W = solver.inverse_columns(self.dofs)
        S = np.eye(self.dofs.size) + self.W[self.dofs] @ self.D
        self._lu = sla.lu_factor(S)

    def apply(self, y: np.ndarray) -> np.ndarray:
        """(A + E D E^T)^-1 r from y = A^-1 r (n,)."""
        return y - self.W @ (self.D @ sla.lu_solve(self._lu, y[self.dofs]))


class LinearSolveError(RuntimeError):
    """The stiffness matrix could not be factorised (singular)."""


def default_backend() -> str:
    """'pardiso' where MKL PARDISO loads, else 'superlu'. pypardiso makes a solver when it is
    imported, and that solver walks the whole environment for MKL (about 0.4 s idle, seconds on
    a busy disk) unless ``PYPARDISO_MKL_RT`` names the library: it is set first."""
    _point_pypardiso_at_mkl()
    try:
        import pypardiso  # noqa: F401
    except Exception:  # MKL missing or not loadable
        return "superlu"
    return "pardiso"


#: PARDISO settings (1-based iparm numbers as in the MKL manual): user settings on, METIS ordering,
#: pivots perturbed by 1e-8, no scaling or weighted matching (the tangent is symmetric and well
#: scaled), iterative refinement only after a perturbed pivot (README, "Solver choices").
PARDISO_IPARM = {1: 1, 2: 2, 8: 0, 10: 8, 11: 0, 13: 0}


def _mkl_runtime_beside_python() -> str | None:
    """MKL's runtime library where pip and conda put it (``lib`` or ``Library/bin`` of the
    environment), found without walking the whole environment (pypardiso's own search takes
    about 0.4 s, paid by every new process: a campaign worker, a CLI call)."""
    import glob
    import sys

    for pattern in ("lib/libmkl_rt.so*", "lib/libmkl_rt*.dylib", "Library/bin/mkl_rt*.dll"):
        hits = sorted(glob.glob(os.path.join(sys.prefix, pattern)), key=len)
        if hits:
            return hits[0]
    return None


def _point_pypardiso_at_mkl() -> None:
    """Name MKL's runtime for pypardiso (``PYPARDISO_MKL_RT``) before it is first imported."""
    if "PYPARDISO_MKL_RT" not in os.environ:
        found = _mkl_runtime_beside_python()
        if found is not None:
            os.environ["PYPARDISO_MKL_RT"] = found


def _new_pardiso():
    """A symmetric-indefinite PARDISO solver. pypardiso looks for MKL by walking the whole
    environment folder (about 0.4 s) unless ``PYPARDISO_MKL_RT`` names the library, so the
    library is looked up beside Python first, and the path the first solver of a process used
    is recorded there for the next ones (a campaign worker runs hundreds)."""
    _point_pypardiso_at_mkl()
    import pypardiso

    solver = pypardiso.PyPardisoSolver(mtype=-2)
    for i, value in PARDISO_IPARM.items():
        solver.set_iparm(i, value)
    os.environ.setdefault("PYPARDISO_MKL_RT", solver.libmkl._name)
    return solver


#: A factorisation keeps at most ``MAX_EXTRA`` columns of W = A^-1 E_C (the dofs held beyond its
#: own, and the contact's low-rank correction), fewer on a mesh so large that they would pass
#: ``EXTRA_COLUMNS_DOUBLES`` doubles (about 1 GB). The correction of the contact's changed cells
#: is capped by it (forward.penalty_contact): at 2e7 doubles contact-L4 (222,264 dofs) kept 90
#: columns, seven cells, and friction's GMRES made up the rest on an old factorisation until it
#: failed; with 400, R = 8 mm {7, 520} kPa mu 0.3, step 8: factorisations 25 -> 10, Krylov
#: iterations 1,203 -> 87, back-substitutions 1,362 -> 160, force within 7.7e-7
#: (docs/validation/solver-and-speed.md, "The correction's columns on the finest level").
MAX_EXTRA = 400
EXTRA_COLUMNS_DOUBLES = 120_000_000

#: The counters a :class:`ConstrainedSymmetricSolver` keeps (in its ``stats``, which may be its
#: caller's dict): PARDISO's symbolic analysis (once per run) and numerical factorisations apart,
#: back-substitutions (calls, right-hand-side columns, seconds; those of
#: :meth:`ConstrainedSymmetricSolver.inverse_columns`, the Schur complement's and the low-rank
#: corrections' columns, also counted on their own).
LINEAR_STATS: dict[str, float] = {
    "symbolic_analyses": 0,
    "symbolic_s": 0.0,
    "numeric_factorizations": 0,
    "numeric_factorize_s": 0.0,
    "back_substitutions": 0,
    "back_substitution_columns": 0,
    "back_substitution_s": 0.0,
    "inverse_column_solves": 0,
    "inverse_columns": 0,
    "inverse_columns_s": 0.0,
}


class ConstrainedSymmetricSolver:
    """Factorise K with a set of constrained dofs eliminated, then solve for many right-hand sides."""

    def __init__(
        self,
        pattern: SparsePattern,
        backend: str | None = None,
        permanent: np.ndarray | None = None,
        single_precision: bool = False,
        stats: dict | None = None,
    ) -> None:
        """``permanent`` (n,) marks dofs constrained for the whole run (supports, symmetry
        planes): they are dropped from the factorised system altogether. ``single_precision``
        (PARDISO only) factorises in float32 (iparm 28), about twice as fast: for callers that use
        the factorisation as a preconditioner or in corrections checked by a residual. ``stats``:
        a dict the counters of ``LINEAR_STATS`` are added to (the solver's own, made here if None)."""
        #: counts and seconds of the analysis, factorisations and back-substitutions (LINEAR_STATS)
        self.stats = {} if stats is None else stats
        for key, zero in LINEAR_STATS.items():
            self.stats.setdefault(key, zero)
        self.pattern = pattern
        self.backend = backend or default_backend()
        if self.backend not in ("pardiso", "superlu"):
            raise ValueError(f"unknown linear solver {self.backend!r}; use 'pardiso' or 'superlu'")
        self.single_precision = bool(single_precision) and self.backend == "pardiso"
        n = pattern.n_dofs
        self.permanent = np.zeros(n, bool) if permanent is None else np.asarray(permanent, bool)
        self.kept = np.flatnonzero(~self.permanent)
        new_index = np.full(n, -1, dtype=np.int64)
        new_index[self.kept] = np.arange(self.kept.size)
        self.m = int(self.kept.size)
        row, col = pattern.row, pattern.indices
        keep = ~self.permanent[row] & ~self.permanent[col]
        is_diag = keep & (row == col)
        self._diag_slot = np.full(n, -1, dtype=np.int64)
        self._diag_slot[row[is_diag]] = np.flatnonzero(is_diag)
        for name, sel in (("_full", keep), ("_upper", keep & (col >= row))):
            slots = np.flatnonzero(sel)  # CSR order: rows ascending, columns ascending
            r = new_index[row[slots]]
            setattr(self, name + "_slots", slots)
            setattr(self, name + "_indices", new_index[col[slots]].astype(np.int32))
            setattr(self, name + "_indptr", np.searchsorted(r, np.arange(self.m + 1)).astype(np.int32))
        self._pardiso = None
        self._analysed = False
        self._lu = None
        self._matrix = None
        #: the dofs constrained in the factorisation in hand (None: no factorisation)
        self.factor_mask: np.ndarray | None = None
        #: at most this many dofs constrained beyond the factorisation's (W is n x this)
        self.max_extra = int(min(MAX_EXTRA, max(32, EXTRA_COLUMNS_DOUBLES // max(n, 1))))
        self._reset_extra()

    def _reset_extra(self) -> None:
        self._column_of = np.full(self.pattern.n_dofs, -1, dtype=np.int64)  # extra dof -> column of W
        self._W = np.zeros((self.pattern.n_dofs, 0))
        self._schur: tuple[bytes, tuple] | None = None

    def factorize(self, K: sp.csr_matrix, constrained: np.ndarray) -> None:
        """Factorise ``K`` (assembled on this pattern) with the ``constrained`` (n,) dofs
        eliminated (zero row and column, unit diagonal)."""
        self.factor_mask = None
        self._reset_extra()
        data = K.data.copy()
        p = self.pattern
        data[constrained[p.row] | constrained[p.indices]] = 0.0
        free_diag = constrained & ~self.permanent
        data[self._diag_slot[free_diag]] = 1.0
        try:
            if self.backend == "pardiso":
                self._factorize_pardiso(data)
            else:  # SuperLU orders and factorises in one call: counted as numerical
                t = time.perf_counter()
                A = sp.csr_matrix(
                    (data[self._full_slots], self._full_indices, self._full_indptr), shape=(self.m, self.m)
                )
                self._lu = spla.splu(
                    A.tocsc(),
                    permc_spec="MMD_AT_PLUS_A",
                    diag_pivot_thresh=0.0,
                    options={"SymmetricMode": True},
                )
                self.stats["numeric_factorizations"] += 1
                self.stats["numeric_factorize_s"] += time.perf_counter() - t
        except LinearSolveError:
            raise
        except Exception as exc:  # pypardiso / SuperLU report singularity in their own types
            raise LinearSolveError(f"{self.backend}: {exc}") from exc
        self.factor_mask = np.asarray(constrained, bool).copy()

    def covers(self, constrained: np.ndarray) -> bool:
        """Whether :meth:`solve_constrained` can take ``constrained``: every dof the factorisation
        constrained is still constrained, and at most ``max_extra`` more are."""
        if self.factor_mask is None or np.any(self.factor_mask & ~constrained):
            return False
        return int(np.count_nonzero(constrained & ~self.factor_mask)) <= self.max_extra

    def solve_constrained(self, rhs: np.ndarray, constrained: np.ndarray) -> np.ndarray:
        """Solve with the last factorisation and the dofs in ``constrained`` (a superset of the
        factorisation's, see :meth:`covers`) held at zero: the Schur complement of the module
        docstring on the extra ones. ``rhs`` (n,) or (n, m) is zeroed there."""
        extra = np.flatnonzero(constrained & ~self.factor_mask)
        if extra.size == 0:
            return self.solve(rhs)
        r = np.array(rhs, dtype=float)
        r[extra] = 0.0
        y = self.solve(r)
        W = self.inverse_columns(extra)
        key = extra.tobytes()
        if self._schur is None or self._schur[0] != key:
            S = W[extra]
            self._schur = (key, sla.lu_factor(0.5 * (S + S.T)))
        lam = sla.lu_solve(self._schur[1], y[extra])
        y = y - W @ lam
        y[extra] = 0.0
        return y

    def inverse_columns(self, dofs: np.ndarray) -> np.ndarray:
        """The columns ``dofs`` of the factorised matrix's inverse, A^-1 E (n, len(dofs)), each
        computed once per factorisation (one multi-right-hand-side back-substitution for those
        not in hand yet; the columns kept are dropped first where they would number more than
        ``max_extra``). A column of a dof the factorisation constrains is zero."""
        dofs = np.asarray(dofs, dtype=np.int64)
        missing = np.unique(dofs[self._column_of[dofs] < 0])
        if missing.size and self._W.shape[1] + missing.size > max(self.max_extra, np.unique(dofs).size):
            self._reset_extra()  # at most max_extra columns kept: start again with those asked for
            missing = np.unique(dofs)
        if missing.size:
            t = time.perf_counter()
            unit = np.zeros((self.pattern.n_dofs, missing.size))
            unit[missing, np.arange(missing.size)] = 1.0
            unit[self.factor_mask] = 0.0
            self._column_of[missing] = self._W.shape[1] + np.arange(missing.size)
            self._W = np.hstack([self._W, self.solve(unit).reshape(-1, missing.size)])
            self.stats["inverse_column_solves"] += 1
            self.stats["inverse_columns"] += int(missing.size)
            self.stats["inverse_columns_s"] += time.perf_counter() - t
        return self._W[:, self._column_of[dofs]]

    def _factorize_pardiso(self, data: np.ndarray) -> None:
        if self._pardiso is None:
            self._pardiso = _new_pardiso()
            self._pardiso.set_iparm(28, int(self.single_precision))
        # PARDISO reads the upper triangle of a symmetric matrix
        A = sp.csr_matrix(
            (data[self._upper_slots], self._upper_indices, self._upper_indptr), shape=(self.m, self.m)
        )
        self._pardiso._check_A(A)  # pypardiso's checks want float64; PARDISO reads float32 if iparm 28
        if self.single_precision:
            A.data = A.data.astype(np.float32)
        b = np.zeros((self.m, 1), dtype=A.dtype)
        if not self._analysed:
            t = time.perf_counter()
            self._pardiso.set_phase(11)
            self._pardiso._call_pardiso(A, b)
            self._analysed = True
            self.stats["symbolic_analyses"] += 1
            self.stats["symbolic_s"] += time.perf_counter() - t
        t = time.perf_counter()
        self._pardiso.set_phase(22)
        self._pardiso._call_pardiso(A, b)
        self.stats["numeric_factorizations"] += 1
        self.stats["numeric_factorize_s"] += time.perf_counter() - t
        self._matrix = A

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """Solve with the last factorisation; ``rhs`` (n,) or (n, m) must be zero at the
        constrained dofs, and so is the solution."""
        t = time.perf_counter()
        b = rhs[self.kept]
        if self.backend == "pardiso":
            self._pardiso.set_phase(33)
            b = np.asfortranarray(b.reshape(self.m, -1), dtype=self._matrix.dtype)
            y = self._pardiso._call_pardiso(self._matrix, b).reshape(rhs[self.kept].shape)
        else:
            y = self._lu.solve(b)
        if not np.all(np.isfinite(y)):
            raise LinearSolveError(f"{self.backend}: non-finite solution (singular stiffness?)")
        x = np.zeros(rhs.shape)
        x[self.kept] = y
        self.stats["back_substitutions"] += 1
        self.stats["back_substitution_columns"] += 1 if rhs.ndim == 1 else int(rhs.shape[1])
        self.stats["back_substitution_s"] += time.perf_counter() - t
        return x

    def __del__(self) -> None:
        self.release()

    def release(self) -> None:
        """Free the solver's memory (PARDISO keeps its factors outside Python)."""
        if getattr(self, "_pardiso", None) is not None:
            self._pardiso.free_memory(everything=True)
            self._pardiso = None
            self._analysed = False
        self.factor_mask = None
        if hasattr(self, "_column_of"):
            self._reset_extra()
