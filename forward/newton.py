"""Newton-Raphson for the embedded solver: the constrained Newton solve with prescribed dofs,
shared by every contact (:mod:`forward.indenter_contact`), on the linear steps of
:mod:`forward.linear_steps` and :mod:`forward.sensitivity_solves` (docs/architecture.md, "forward").

:class:`NewtonSystem` is the base of :class:`forward.solver.EmbeddedSolver`, which provides
:meth:`NewtonSystem.assemble`.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from .linear_solver import LinearSolveError
from .material import InvertedElementError
from .sensitivity_solves import SensitivitySolves

if TYPE_CHECKING:
    from .block_mesh import BlockMesh
    from .sparse_assembly import SparsePattern
    from .spec import ModelSpec
    from .stick_contact import RigidSphere

__all__ = [
    "MAX_HALVINGS",
    "MAX_STALE_STEPS",
    "REFACTOR_RATIO",
    "Equilibrium",
    "IncrementFailed",
    "NewtonSystem",
]

log = logging.getLogger(__name__)


class IncrementFailed(Exception):
    """An increment that did not converge (cut back by the solver's driver)."""


#: A correction keeps the current factorisation while the residual shrinks at least this much.
REFACTOR_RATIO = 0.3
#: ... and for at most this many corrections in a row.
MAX_STALE_STEPS = 6
#: A Newton step that inverts an element is halved at most this many times.
MAX_HALVINGS = 6


@dataclass
class Equilibrium:
    """A converged state.

    Parameters
    ----------
    u : ndarray, shape (n, 3)
        Displacements, mm.
    R : ndarray, shape (3n,)
        The internal force (= the external force at equilibrium), mN.
    K : scipy.sparse.csr_matrix or None
        The tangent there (with sensitivities).
    iterations : int
        Newton iterations it took.
    dR : ndarray, shape (3n, p), optional
        d(internal force)/d(theta) at ``u`` (with sensitivities).
    """

    u: np.ndarray  # (n, 3)
    R: np.ndarray  # (3n,) internal force = external force at equilibrium
    K: sp.csr_matrix
    iterations: int
    dR: np.ndarray | None = None  # (3n, p): d(internal force)/d(theta) at u


class NewtonSystem(SensitivitySolves):
    """The constrained Newton solve of the embedded solver, on its linear steps.

    Subclasses (forward.solver.EmbeddedSolver) set the attributes below and those of
    :class:`forward.sensitivity_solves.SensitivitySolves` (on
    :class:`forward.linear_steps.LinearSteps`), and provide :meth:`assemble`.

    Attributes
    ----------
    spec : ModelSpec
        The model (its solver options).
    force_scale : float
        A force below which residuals count as zero, mN.
    want_sensitivities : bool
        Whether the run asks for d/dtheta (equilibria then carry their tangent and dR/dtheta).
    """

    spec: ModelSpec
    mesh: BlockMesh
    pattern: SparsePattern
    top: np.ndarray
    bc_fixed: np.ndarray
    sphere: RigidSphere
    force_scale: float
    want_sensitivities: bool

    def assemble(
        self, u: np.ndarray, tangent: bool = True, parameter_derivatives: bool = False
    ) -> tuple[np.ndarray, sp.csr_matrix | None, np.ndarray | None]:
        """The internal force, tangent and dR/dtheta at a state (the subclass's).

        Parameters
        ----------
        u : ndarray, shape (n, 3)
            Displacements.
        tangent : bool, optional
            Whether to assemble the tangent.
        parameter_derivatives : bool, optional
            Whether to assemble dR/dtheta.

        Returns
        -------
        tuple
            R (3n,), K (CSR or None), dR (3n, 2) or None.
        """
        raise NotImplementedError

    def equilibrate(self, u0: np.ndarray, cmask: np.ndarray, target: np.ndarray) -> Equilibrium:
        """Newton-Raphson to equilibrium with the dofs in ``cmask`` prescribed to ``target``.

        Parameters
        ----------
        u0 : ndarray, shape (n, 3)
            The starting state.
        cmask : ndarray of bool, shape (3n,)
            The prescribed dofs (supports, symmetry planes, attached nodes).
        target : ndarray
            Their prescribed displacements (one per dof in ``cmask``).

        Returns
        -------
        Equilibrium

        Raises
        ------
        IncrementFailed
            No convergence in ``max_newton`` iterations, an inverted element or a failed solve.

        Notes
        -----

        The first iteration carries the prescribed increments into the body through the exact
        tangent (consistent predictor). The corrections reuse that factorisation while the
        residual contracts by at least ``REFACTOR_RATIO`` per iteration (``MAX_STALE_STEPS`` in
        a row at most) and take a Newton step with the tangent at the current state otherwise
        (:meth:`newton_step`), so most corrections cost a residual and a back-substitution. A correction with an old factorisation that makes
        the residual worse is undone and redone as a full Newton step; a step that inverts an
        element is halved. The residual is checked on the free dofs against the reactions."""
        opts = self.spec.solver
        u = u0.reshape(-1).copy()
        jump = np.zeros(self.n_dofs)
        jump[cmask] = target - u[cmask]
        want_dR = self.want_sensitivities
        self.begin_newton_solve()
        try:
            R, K, _ = self.assemble(u.reshape(-1, 3))
            rhs = -(R + K @ jump)
            rhs[cmask] = 0.0
            # the first step: the constrained dofs jump to their targets, the free ones follow by
            # a Newton step; if that inverts an element, it is halved like any other (below)
            u_prev = u + jump
            du = -self.newton_step(K, cmask, rhs)
            u = u_prev - du
            last = np.inf  # residual norm before the last step
            fresh_step = False  # the last step was taken with a factorisation made at its start
            halvings = 0
            stale_steps = 0  # corrections in a row with the same factorisation
            for it in range(1, opts.max_newton + 1):
                try:
                    R, _, _ = self.assemble(u.reshape(-1, 3), tangent=False)
                except InvertedElementError:
                    if halvings >= MAX_HALVINGS:
                        raise
                    halvings += 1  # the step inverted an element: halve it
                    log.debug("newton %d: an element inverted, step halved (%d)", it, halvings)
                    du *= 0.5
                    u = u_prev - du
                    continue
                norm = np.linalg.norm(np.where(cmask, 0.0, R))
                ref = max(np.linalg.norm(R[cmask]), self.force_scale)
                log.debug("newton %d: residual %.3e of %.3e", it, norm, ref)
                at_round_off = fresh_step and norm > 0.5 * last and norm <= 1e-6 * ref
                if norm <= opts.residual_tol * ref or at_round_off:
                    K = dR = None
                    if want_dR:
                        _, K, dR = self.assemble(u.reshape(-1, 3), parameter_derivatives=True)
                    return Equilibrium(u.reshape(-1, 3), R, K, it, dR)
                if norm > last and not fresh_step:  # a step with an old factorisation made it worse: undo it
                    u, norm = u_prev, last
                    R, _, _ = self.assemble(u.reshape(-1, 3), tangent=False)
                worn = norm > REFACTOR_RATIO * last or stale_steps >= MAX_STALE_STEPS
                r_free = np.where(cmask, 0.0, R)
                fresh_step = worn or norm == last
                if fresh_step:  # a Newton step with the tangent here
                    du = self.newton_step(self.assemble(u.reshape(-1, 3))[1], cmask, r_free)
                    stale_steps = 0
                else:  # a correction with the factorisation made elsewhere
                    du = self.solve(r_free, cmask)
                last, u_prev = norm, u.copy()
                u = u - du
                stale_steps += 1
        except (InvertedElementError, LinearSolveError) as exc:
            raise IncrementFailed(str(exc)) from exc
        raise IncrementFailed(f"Newton did not converge in {opts.max_newton} iterations")
