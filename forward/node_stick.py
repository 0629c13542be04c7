"""The paper's near-perfect stick imposed exactly, node by node, behind
:class:`forward.indenter_contact.IndenterContact` (the contact law: :mod:`forward.stick_contact`).

A free top node whose path in an increment meets the sphere is attached where it first crosses
it and from then on moves with the indenter (its three displacements prescribed); an attached
node whose reaction pulls on the sphere is released. Each increment is solved by the constrained
Newton of :meth:`forward.newton.NewtonSystem.equilibrate`, re-solved until no free node
penetrates and no attached node pulls; the indenter force is the sum of the attached nodes'
vertical reactions.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from .indenter_contact import IndenterContact
from .newton import Equilibrium, IncrementFailed, NewtonSystem
from .stick_contact import StickContactState

if TYPE_CHECKING:
    from .linear_solver import LowRankUpdate

__all__ = ["NodeStickContact"]


class NodeStickContact(IndenterContact):
    """The exact node-wise stick (module docstring).

    Parameters
    ----------
    solver : NewtonSystem
        The solver it belongs to (forward.solver.EmbeddedSolver).
    """

    parameters = ("c1", "c5")
    symmetric = True

    def __init__(self, solver: NewtonSystem) -> None:
        super().__init__(solver)

    # ------------------------------------------------------------------ the interface
    def start(self) -> StickContactState:
        s = self.solver
        return StickContactState(s.sphere, s.mesh.nodes[s.top])

    def add_to_system(self, u: np.ndarray, R: np.ndarray, K: sp.csr_matrix | None) -> None:
        return None  # its forces are the attached nodes' reactions

    def for_factorisation(self, K: sp.csr_matrix) -> sp.csr_matrix:
        return K

    def correction(self, cmask: np.ndarray) -> LowRankUpdate | None:
        return None  # attached nodes are constraints: the factorisation covers them by its Schur complement

    def quarter_force(self, eq: Equilibrium, state: StickContactState) -> float:
        s = self.solver
        return -float(np.sum(eq.R.reshape(-1, 3)[s.top[state.attached], 2]))

    def quarter_force_sensitivity(
        self, eq: Equilibrium, state: StickContactState, du_dtheta: np.ndarray
    ) -> np.ndarray:
        s = self.solver
        n_p = du_dtheta.shape[-1]
        dRc = eq.dR + eq.K @ du_dtheta.reshape(-1, n_p)
        return -dRc.reshape(-1, 3, n_p)[s.top[state.attached], 2].sum(axis=0)

    def node_status(self, state: StickContactState) -> tuple[np.ndarray, np.ndarray]:
        return state.attached.copy(), np.zeros_like(state.attached)

    def describe(self) -> str:
        return "rigid sphere, node-to-surface stick (attach at path crossing, release on tension)"

    # ------------------------------------------------------------------ its numerics
    def constraints(self, state: StickContactState, depth: float) -> tuple[np.ndarray, np.ndarray]:
        """The dofs a contact state prescribes at a depth, with the supports and symmetry planes.

        Parameters
        ----------
        state : StickContactState
            Which top nodes are attached, and where on the sphere.
        depth : float
            The indenter's depth, mm.

        Returns
        -------
        tuple of ndarray
            The mask of constrained dofs (3n,) and their prescribed displacements.
        """
        s = self.solver
        mask = s.bc_fixed.copy()
        values = np.zeros((s.mesh.n_nodes, 3))
        att = s.top[state.attached]
        mask[att] = True
        values[att] = state.prescribed_displacement(depth)[state.attached]
        values[s.bc_fixed] = 0.0
        mask = mask.ravel()
        return mask, values.ravel()[mask]

    def _reaction_top(self, R: np.ndarray) -> np.ndarray:
        """External force on the top nodes, with the components that symmetry planes carry zeroed."""
        s = self.solver
        r = R.reshape(-1, 3)[s.top].copy()
        on_x = np.isin(s.top, s.mesh.xsym)
        on_y = np.isin(s.top, s.mesh.ysym)
        r[on_x, 0] = 0.0
        r[on_y, 1] = 0.0
        return r

    def increment(
        self,
        u: np.ndarray,
        u_pred: np.ndarray,
        d0: float,
        d1: float,
        state: StickContactState,
        du_start: np.ndarray | None,
        du_pred: np.ndarray | None = None,
    ) -> tuple[Equilibrium, StickContactState, int, int, np.ndarray | None]:
        # the interface's increment: attach, solve, release and re-attach until settled
        s = self.solver
        c = state.copy()
        u_top0 = u[s.top]
        released = np.zeros_like(c.attached)
        trial = u_pred
        iters = 0
        tol_pen = 1e-9 * s.sphere.radius
        sens = None
        # nodes the predicted state pushes into the sphere are attached where the predicted path
        # crosses its surface, which usually spares a second contact pass
        s0_top = du_start[s.top] if du_start is not None else None
        sp_top = du_pred[s.top] if du_pred is not None else None
        ahead = np.flatnonzero(c.penetrating(u_pred[s.top], d1, tol_pen))
        c.attach(ahead, u_top0, d0, u_pred[s.top], d1, s0_top, sp_top)
        for passes in range(1, s.spec.solver.max_contact_passes + 1):
            cmask, target = self.constraints(c, d1)
            eq = s.equilibrate(trial, cmask, target)
            iters += eq.iterations
            trial = eq.u
            normal = c.normal_reaction(self._reaction_top(eq.R))
            tol_t = 1e-9 * max(float(np.abs(normal).max(initial=0.0)), s.force_scale)
            pulling = c.attached & (normal < -tol_t)
            pen = c.penetrating(trial[s.top], d1, tol_pen)
            # the state's derivatives: for the result, or for the anchors of the nodes this pass
            # attaches (a pass that only releases nodes needs none)
            sens = (
                self._sensitivity(eq, cmask, c)
                if s.want_sensitivities and (pen.any() or not pulling.any())
                else None
            )
            if not pulling.any() and not pen.any():
                return eq, c, iters, passes, sens
            c.attached[pulling] = False
            released |= pulling
            s_top = sens[s.top] if sens is not None else None
            again = np.flatnonzero(pen & released)  # slipped back in: re-attach where it is now
            c.attach(again, trial[s.top], d1, trial[s.top], d1, s_top, s_top)
            new = np.flatnonzero(pen & ~released)
            c.attach(new, u_top0, d0, trial[s.top], d1, s0_top, s_top)
        raise IncrementFailed("the contact set did not settle")

    def _sensitivity(self, eq: Equilibrium, cmask: np.ndarray, contact: StickContactState) -> np.ndarray:
        """d u / d theta (n, 3, p) of a converged state: K_ff du_f = -(dR_f + K_fc du_c), where
        du_c is the anchors' derivative at attached nodes (0 at supports). Solved by CG on the
        exact converged tangent, preconditioned with the factorisation in hand."""
        s = self.solver
        n_p = eq.dR.shape[1]
        jump = np.zeros((s.mesh.n_nodes, 3, n_p))
        att = s.top[contact.attached]
        jump[att] = contact.danchor[contact.attached]
        jump[s.bc_fixed] = 0.0
        jump = jump.reshape(-1, n_p)
        b = -(eq.dR + eq.K @ jump)
        b[cmask] = 0.0
        x = s.sensitivity_solve(eq.K, cmask, b)
        return (x + jump).reshape(-1, 3, n_p)
