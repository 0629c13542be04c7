"""The embedded solver's linear steps: factorisations, Krylov solves preconditioned with the
factorisation in hand and back-substitutions (docs/architecture.md, "forward"); the sensitivity
solves on them are :mod:`forward.sensitivity_solves`.

:class:`LinearSteps` is the base of :class:`forward.sensitivity_solves.SensitivitySolves`, and so
of :class:`forward.newton.NewtonSystem` and :class:`forward.solver.EmbeddedSolver`: it holds the linear solver and the statistics, and asks
the contact in use (``self.contact``) what the tangent's factorisation leaves out
(:meth:`IndenterContact.for_factorisation`, :meth:`IndenterContact.correction`) and whether the
tangent is symmetric. The Newton solve that calls these steps is :mod:`forward.newton`.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Protocol

import numpy as np
import scipy.sparse as sp

from .krylov_solve import krylov_solve
from .linear_solver import LowRankUpdate

if TYPE_CHECKING:
    from .linear_solver import ConstrainedSymmetricSolver

__all__ = [
    "FRESH_MAXITER",
    "FRESH_RTOL",
    "GMRES_CYCLES",
    "KINK_CROSSINGS",
    "KINK_DOFS",
    "KRYLOV_RTOL",
    "LINEAR_STEP_STATS",
    "TRIES_FAILED_IN_A_ROW",
    "WORN_KRYLOV",
    "LinearSteps",
    "TangentContact",
]

#: Newton steps are solved by CG preconditioned with the factorisation in hand to this relative
#: residual, in at most this many iterations, before a new factorisation is made.
KRYLOV_RTOL = 1e-2
KRYLOV_MAXITER = 8
#: ... or more where a factorisation costs many back-substitutions (large meshes).
KRYLOV_MAXITER_LARGE = 30
KRYLOV_DOFS_PER_ITERATION = 3000
#: A factorisation is worn once a CG solve on it (the stick's symmetric tangent) took more than this fraction of
#: :meth:`LinearSteps.krylov_maxiter`: the next Newton step factorises instead of trying it again.
#: On a large mesh CG on an old factorisation often takes 10 to 20 iterations for many Newton
#: steps in a row before one fails, while a factorisation costs about 25 of them: contact-L3
#: {10, 350} kPa 150.3 -> 117.8 s, contact-L4 R = 8 mm {14, 200} (6 steps) 268.0 -> 251.5 s, the
#: small meshes unchanged within noise (docs/validation/solver-and-speed.md, "a worn factorisation").
WORN_KRYLOV = 0.5
#: With friction, on a mesh of at least ``KINK_DOFS`` dofs, a Newton step factorises at once
#: (instead of trying GMRES on the factorisation in hand) where more than ``KINK_CROSSINGS`` Gauss
#: points' fibers crossed stretch 1 since that factorisation's tangent: the fibers' stiffness
#: c5 / 4 (dI4 x dI4) comes or goes there at once and the old factorisation stops preconditioning
#: the new tangent (contact-L1 R = 8 {1.5, 100} mu 0.3: of 354 solves with more than 30 crossed,
#: 92 % failed; of 512 with none, none). contact-L3 {3, 540} mu 0.3, 4 steps, 554 -> 390 s; on
#: smaller meshes a factorisation costs less than the tries it replaces (contact-L1 12.2 ->
#: 15.0 s), hence the size (docs/validation/solver-and-speed.md, "across the fibers' kink").
KINK_CROSSINGS = 30
KINK_DOFS = 20_000
#: Under the stick, once this many Krylov tries of a Newton solve failed in a row (each on a
#: factorisation made after the last failed), its later Newton steps factorise at once: far from
#: equilibrium each Newton step changes the tangent so much that the one before preconditions it
#: no better than nothing (CG's first iterate leaves 0.7 to 1.1 of the residual). contact-L4, R =
#: 4.77 mm, {3, 120} kPa, step 1: 18 such tries in a row, 30 iterations each; on contact-L3 tries
#: that fail come alone (9 of 137 over 28 steps) and the rule changes nothing
#: (docs/validation/solver-and-speed.md, "Failed tries in a row").
TRIES_FAILED_IN_A_ROW = 2
#: With friction, a step made with a fresh factorisation is GMRES on the tangent to this relative
#: residual, in at most this many iterations (LinearSteps.fresh_step).
FRESH_RTOL = 1e-8
FRESH_MAXITER = 50
#: On a factorisation just made (a fresh step, a sensitivity solve that factorised), GMRES
#: (friction's unsymmetric tangent) runs at most this many cycles of its iterations. scipy's GMRES
#: ends a cycle when the preconditioned residual meets the tolerance and only then checks the true
#: one, so that a solve of one cycle whose true residual was not yet there counted as failed and
#: its step was thrown away for the factorisation's own, of the tangent's symmetric part, which
#: need not lower the residual: contact-L3, R = 8 mm, {20, 560} kPa, mu 0.3, Newton stalled in
#: step 26 for 2,440 s, 74 s with three cycles beside four other jobs (docs/validation/
#: solver-and-speed.md, "GMRES's second cycle"). A Newton step on an older factorisation keeps one
#: cycle: where it fails, a factorisation is made, which on small meshes costs less than more
#: cycles (contact-L0 {3, 540} mu 0.3: 5.9 -> 8.1 s CPU with three for every solve).
GMRES_CYCLES = 3

#: The counters of the linear steps (:attr:`LinearSteps.stats`; the solver's driver adds those of
#: the assemblies, the linear solver and the contact). ``solve_s`` is the time of every linear step
#: (factorisations, Krylov solves, corrections' back-substitutions); ``krylov_s`` includes the
#: matrix products and the preconditioner's applications (back-substitutions and the contact's
#: correction) inside it; the ``sensitivity_`` counters are the sensitivity solves' share of the rest.
LINEAR_STEP_STATS: dict[str, float] = {
    "factorizations": 0,
    "factorize_s": 0.0,
    "fresh_steps": 0,
    "solves": 0,
    "solve_s": 0.0,
    "krylov_calls": 0,
    "krylov_failures": 0,
    "krylov_steps": 0,
    "krylov_iterations": 0,
    "krylov_s": 0.0,
    "krylov_matvecs": 0,
    "krylov_matvec_s": 0.0,
    "preconditioner_applications": 0,
    "preconditioner_s": 0.0,
    "correction_applications": 0,
    "correction_apply_s": 0.0,
    "sensitivity_solves": 0,
    "sensitivity_columns": 0,
    "sensitivity_s": 0.0,
    "sensitivity_factorizations": 0,
    "sensitivity_krylov_iterations": 0,
    "kink_refactorisations": 0,
    "streak_refactorisations": 0,
}


class TangentContact(Protocol):
    """What the linear steps ask of the contact in use (forward.indenter_contact.IndenterContact)."""

    symmetric: bool

    def for_factorisation(self, K: sp.csr_matrix) -> sp.csr_matrix: ...

    def correction(self, cmask: np.ndarray) -> LowRankUpdate | None: ...


class LinearSteps:
    """The linear steps of the embedded solver's Newton solve (module docstring).

    Subclasses (:class:`forward.newton.NewtonSystem`, then :class:`forward.solver.EmbeddedSolver`)
    set the attributes below.

    Attributes
    ----------
    linear : ConstrainedSymmetricSolver
        The linear solver (factorisations and back-substitutions).
    contact : TangentContact
        The contact in use (what the factorisation leaves out).
    stats : dict
        Counts and times of assemblies, factorisations, solves and Krylov iterations
        (``LINEAR_STEP_STATS``, the linear solver's ``LINEAR_STATS`` and the contact's).
    n_dofs : int
        The model's degrees of freedom.
    fiber_taut : ndarray of bool, shape (ne, 8) or None
        Which Gauss points' fibers are stretched at the last tangent assembled (the solver sets
        it; :data:`KINK_CROSSINGS`).
    """

    linear: ConstrainedSymmetricSolver
    contact: TangentContact
    stats: dict
    n_dofs: int
    #: whether a Krylov solve on the factorisation in hand took more than ``WORN_KRYLOV`` of its
    #: iterations (the next Newton step factorises)
    _worn: bool = False
    fiber_taut: np.ndarray | None = None
    #: ``fiber_taut`` of the tangent in the factorisation in hand
    _taut_factorised: np.ndarray | None = None
    #: Krylov tries of this Newton solve that failed in a row (:data:`TRIES_FAILED_IN_A_ROW`)
    _failed_in_a_row: int = 0

    def begin_newton_solve(self) -> None:
        """Start counting a Newton solve's failed Krylov tries afresh (:data:`TRIES_FAILED_IN_A_ROW`)."""
        self._failed_in_a_row = 0

    def factorize(self, K: sp.csr_matrix, constrained: np.ndarray) -> None:
        """Factorise a tangent (with friction, its symmetric part: :meth:`IndenterContact.for_factorisation`).

        Parameters
        ----------
        K : scipy.sparse.csr_matrix
            The tangent.
        constrained : ndarray of bool, shape (3n,)
            The dofs eliminated.
        """
        t = time.perf_counter()
        self.linear.factorize(self.contact.for_factorisation(K), constrained)
        self._worn = False
        self._taut_factorised = self.fiber_taut
        dt = time.perf_counter() - t
        self.stats["factorizations"] += 1
        self.stats["factorize_s"] += dt
        self.stats["solve_s"] += dt

    def krylov_maxiter(self) -> int:
        """How many CG iterations are worth trying before a factorisation.

        A factorisation's cost grows faster than a back-substitution's with the mesh, so larger
        meshes try more: one iteration per ``KRYLOV_DOFS_PER_ITERATION`` dofs, within
        ``KRYLOV_MAXITER`` .. ``KRYLOV_MAXITER_LARGE`` (a fixed rule, not a timing, so that a run is
        reproducible to the last digit).

        Returns
        -------
        int
        """
        return int(np.clip(self.n_dofs // KRYLOV_DOFS_PER_ITERATION, KRYLOV_MAXITER, KRYLOV_MAXITER_LARGE))

    def krylov(
        self,
        K: sp.csr_matrix,
        cmask: np.ndarray,
        rhs: np.ndarray,
        rtol: float,
        maxiter: int,
        *,
        cycles: int = 1,
        unfinished: bool = False,
    ) -> np.ndarray | None:
        """CG (GMRES when the tangent is unsymmetric) preconditioned with the factorisation in hand.

        The dofs in ``cmask`` are eliminated (the factorisation's extra constraints by its Schur
        complement) and the contact's :meth:`IndenterContact.correction` is applied.

        Parameters
        ----------
        K : scipy.sparse.csr_matrix
            The tangent.
        cmask : ndarray of bool, shape (3n,)
            The dofs held (eliminated, their solution 0).
        rhs : ndarray, shape (3n,)
            The right-hand side.
        rtol : float
            Relative residual to reach.
        maxiter : int
            Iterations at most (CG); with GMRES, iterations a cycle.
        cycles : int, optional
            GMRES's cycles at most (``GMRES_CYCLES`` on a factorisation just made).
        unfinished : bool, optional
            Return the last iterate also where it does not reach ``rtol`` (still counted as a
            failure), None only where it is not finite.

        Returns
        -------
        ndarray or None
            The solution, or None when it does not reach ``rtol`` within those iterations.
        """
        t = time.perf_counter()
        correction = self.contact.correction(cmask)
        x, iterations, converged = krylov_solve(
            K,
            cmask,
            rhs,
            lambda r: self.precondition(r, cmask, correction),
            symmetric=self.contact.symmetric,
            rtol=rtol,
            maxiter=maxiter,
            cycles=cycles,
            stats=self.stats,
        )
        dt = time.perf_counter() - t
        self.stats["krylov_calls"] += 1
        self.stats["krylov_iterations"] += iterations
        self.stats["krylov_s"] += dt
        self.stats["solve_s"] += dt
        if not converged:
            self.stats["krylov_failures"] += 1
            return np.where(cmask, 0.0, x) if unfinished and np.all(np.isfinite(x)) else None
        self.stats["krylov_steps"] += 1
        return np.where(cmask, 0.0, x)

    def newton_step(
        self, K: sp.csr_matrix, cmask: np.ndarray, rhs: np.ndarray, rtol: float = KRYLOV_RTOL
    ) -> np.ndarray:
        """Solve K x = rhs, the dofs in ``cmask`` eliminated, as cheaply as the factorisation in hand allows.

        By CG (GMRES with friction) preconditioned with the factorisation in hand (to ``rtol``: a
        tangent assembly and a few back-substitutions instead of a factorisation) when that
        factorisation covers the constraints (:meth:`ConstrainedSymmetricSolver.covers`), else,
        or when it does not get there, by factorising K (:meth:`fresh_step`). A factorisation on
        which CG took more than ``WORN_KRYLOV`` of its iterations is worn: the next step
        factorises at once; so does a step with friction on a large mesh across whose tangent
        more than ``KINK_CROSSINGS`` fibers went taut or slack since the factorisation, and a step
        under the stick once ``TRIES_FAILED_IN_A_ROW`` tries of its Newton solve failed in a row.

        Parameters
        ----------
        K : scipy.sparse.csr_matrix
            The tangent.
        cmask : ndarray of bool, shape (3n,)
            The dofs held (eliminated, their solution 0).
        rhs : ndarray, shape (3n,)
            The right-hand side.
        rtol : float, optional
            The Krylov solve's relative residual.

        Returns
        -------
        ndarray, shape (3n,)
        """
        if (
            self.linear.covers(cmask)
            and not self._worn
            and not self._across_the_kink()
            and not self._on_a_streak()
        ):
            maxiter = self.krylov_maxiter()
            before = self.stats["krylov_iterations"]
            x = self.krylov(K, cmask, rhs, rtol, maxiter)
            # with friction the failed solves follow the fibers' kink, not wear (the speed page):
            # its GMRES keeps trying until one fails
            worn = self.stats["krylov_iterations"] - before > WORN_KRYLOV * maxiter
            self._worn = worn and self.contact.symmetric
            self._failed_in_a_row = 0 if x is not None else self._failed_in_a_row + 1
            if x is not None:
                return x
        return self.fresh_step(K, cmask, rhs)

    def _on_a_streak(self) -> bool:
        """Whether, under the stick, this Newton solve's last ``TRIES_FAILED_IN_A_ROW`` Krylov tries failed."""
        streak = self.contact.symmetric and self._failed_in_a_row >= TRIES_FAILED_IN_A_ROW
        self.stats["streak_refactorisations"] += int(streak)
        return streak

    def _across_the_kink(self) -> bool:
        """Whether, with friction on a large mesh, more than ``KINK_CROSSINGS`` Gauss points'
        fibers crossed stretch 1 since the factorisation in hand (:data:`KINK_CROSSINGS`)."""
        if self.contact.symmetric or self.n_dofs < KINK_DOFS:
            return False
        now, then = self.fiber_taut, self._taut_factorised
        if now is None or then is None or now.shape != then.shape:
            return False
        crossed = bool(np.count_nonzero(now != then) > KINK_CROSSINGS)
        self.stats["kink_refactorisations"] += int(crossed)
        return crossed

    def fresh_step(self, K: sp.csr_matrix, cmask: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        """Solve K x = rhs with a factorisation of K made here.

        One back-substitution; with friction GMRES on K itself, preconditioned with it, to
        ``FRESH_RTOL`` in at most ``GMRES_CYCLES`` cycles (the factorisation is of K's symmetric
        part, the contact blocks put back by the contact's correction), else the better by the
        true residual of GMRES's last iterate and that factorisation's own step.

        Parameters
        ----------
        K : scipy.sparse.csr_matrix
            The tangent.
        cmask : ndarray of bool, shape (3n,)
            The dofs held (eliminated, their solution 0).
        rhs : ndarray, shape (3n,)
            The right-hand side.

        Returns
        -------
        ndarray, shape (3n,)
        """
        self.stats["fresh_steps"] += 1
        self.factorize(K, cmask)
        if self.contact.symmetric:
            return self.solve(rhs, cmask)
        x = self.krylov(K, cmask, rhs, FRESH_RTOL, FRESH_MAXITER, cycles=GMRES_CYCLES, unfinished=True)
        if x is not None:
            miss = np.linalg.norm(np.where(cmask, 0.0, K @ x - rhs))
            if miss <= FRESH_RTOL * np.linalg.norm(rhs):
                return x
        # where GMRES does not get there (a correction capped far below the contact set), the
        # better by the true residual of its last iterate and the factorisation's own step (of
        # the tangent's symmetric part), checked by the damped Newton's residual like any other
        own = self.solve(rhs, cmask)
        if x is None or np.linalg.norm(np.where(cmask, 0.0, K @ own - rhs)) < miss:
            return own
        return x

    def solve(self, rhs: np.ndarray, cmask: np.ndarray) -> np.ndarray:
        """One back-substitution with the factorisation in hand.

        Parameters
        ----------
        rhs : ndarray, shape (3n,)
            The right-hand side.
        cmask : ndarray of bool, shape (3n,)
            The dofs held (eliminated, their solution 0).

        Returns
        -------
        ndarray, shape (3n,)
        """
        t = time.perf_counter()
        x = self.precondition(rhs, cmask, self.contact.correction(cmask))
        self.stats["solves"] += 1
        self.stats["solve_s"] += time.perf_counter() - t
        return x

    def precondition(self, r: np.ndarray, cmask: np.ndarray, correction: LowRankUpdate | None) -> np.ndarray:
        """The factorisation in hand applied to a vector, with the contact's correction.

        Parameters
        ----------
        r : ndarray, shape (3n,)
            The vector.
        cmask : ndarray of bool, shape (3n,)
            The dofs held (eliminated, their solution 0).
        correction : LowRankUpdate or None
            The contact blocks' correction (:meth:`IndenterContact.correction`).

        Returns
        -------
        ndarray, shape (3n,)
        """
        y = self.linear.solve_constrained(r, cmask)
        if correction is None:
            return y
        t = time.perf_counter()
        y = correction.apply(y)
        y[cmask] = 0.0
        self.stats["correction_applications"] += 1
        self.stats["correction_apply_s"] += time.perf_counter() - t
        return y
