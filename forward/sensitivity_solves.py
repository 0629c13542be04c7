"""The sensitivity solves of the embedded solver: K x = dR/dtheta at each converged increment, on
the linear steps' factorisations and Krylov solves (:mod:`forward.linear_steps`;
docs/architecture.md, "forward").

:class:`SensitivitySolves` is the base of :class:`forward.newton.NewtonSystem`; the contacts call
:meth:`SensitivitySolves.sensitivity_solve` after an increment converged.
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .linear_solver import LinearSolveError
from .linear_steps import GMRES_CYCLES, LinearSteps

__all__ = ["SENSITIVITY_RTOL", "SensitivitySolves", "unsymmetric_factorisation"]

#: Relative residual of the sensitivity solves (their CG runs on the exact converged tangent).
SENSITIVITY_RTOL = 1e-11


def unsymmetric_factorisation(K: sp.csr_matrix, cmask: np.ndarray) -> spla.SuperLU:
    """An LU factorisation (SuperLU) of K with the dofs in ``cmask`` eliminated.

    The tangent with friction is not symmetric; the Newton solve factorises its symmetric part and
    lets GMRES bridge the rest. Where it cannot, this is K's own factorisation.

    Parameters
    ----------
    K : scipy.sparse.csr_matrix
        The tangent.
    cmask : ndarray of bool, shape (3n,)
        The dofs held (their solution 0).

    Returns
    -------
    scipy.sparse.linalg.SuperLU
        Its ``solve`` takes and returns vectors over the free dofs.

    Raises
    ------
    LinearSolveError
        If K is singular on the free dofs.
    """
    free = np.flatnonzero(~cmask)
    try:
        return spla.splu(K[free][:, free].tocsc())
    except RuntimeError as exc:  # SuperLU: "Factor is exactly singular"
        raise LinearSolveError(f"the tangent is singular ({exc})") from exc


class SensitivitySolves(LinearSteps):
    """The linear steps with the sensitivity solves (module docstring)."""

    #: the factorisation count the last sensitivity solve ended with (-1: none yet)
    _sensitivity_factorisation: int = -1

    def sensitivity_solve(self, K: sp.csr_matrix, cmask: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Solve the sensitivity equations K x = b, column by column, to ``SENSITIVITY_RTOL``.

        Krylov on the exact converged tangent, preconditioned with the factorisation in hand
        (with the contact's correction) when it covers the constraints; where it does not get
        there, K is factorised and the solve repeated. Where the factorisation in hand is the one
        the previous sensitivity solve ended with (no Newton step of this increment made a newer
        one), K is factorised first: CG to ``SENSITIVITY_RTOL`` on an increment-old factorisation
        failed in 24 of 28 steps of contact-L3 {10, 350} kPa and cost more than the factorisation
        (162 -> 135 s CPU in all, forces within 1.4e-6; docs/validation/solver-and-speed.md,
        "Where the time goes"). The factorisation made here preconditions the next increment.

        Parameters
        ----------
        K : scipy.sparse.csr_matrix
            The converged tangent.
        cmask : ndarray of bool, shape (3n,)
            The dofs held (their solution 0).
        b : ndarray, shape (3n, p)
            The right-hand sides, one per parameter.

        Returns
        -------
        ndarray, shape (3n, p)

        Raises
        ------
        LinearSolveError
            A solve that does not converge even with a fresh factorisation.
        """
        t = time.perf_counter()
        before = {k: self.stats[k] for k in ("factorizations", "krylov_iterations")}
        x, lu = np.zeros_like(b), None
        if self.stats["factorizations"] == self._sensitivity_factorisation and self.linear.covers(cmask):
            self.factorize(K, cmask)
        for k in range(b.shape[1]):
            col = (
                self.krylov(K, cmask, b[:, k], SENSITIVITY_RTOL, self.krylov_maxiter())
                if self.linear.covers(cmask)
                else None
            )
            if col is None:  # that factorisation is too far from this tangent: factorise it
                self.factorize(K, cmask)
                col = self.krylov(K, cmask, b[:, k], SENSITIVITY_RTOL, 100, cycles=GMRES_CYCLES)
            if col is None and not self.contact.symmetric:
                # with friction the factorisation is of K's symmetric part; where slip makes the
                # rest too large for GMRES to bridge, K itself is factorised (once for all columns)
                lu = lu or unsymmetric_factorisation(K, cmask)
                col = np.zeros(len(cmask))
                col[~cmask] = lu.solve(b[~cmask, k])
            if col is None:
                raise LinearSolveError("the sensitivity solve did not converge")
            x[:, k] = col
        self._sensitivity_factorisation = self.stats["factorizations"]
        self.stats["sensitivity_solves"] += 1
        self.stats["sensitivity_columns"] += int(b.shape[1])
        self.stats["sensitivity_s"] += time.perf_counter() - t
        for key, was in before.items():
            self.stats["sensitivity_" + key] += self.stats[key] - was
        return x
