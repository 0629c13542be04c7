"""The indenter's penalty contact behind :class:`forward.indenter_contact.IndenterContact`: stick
(mu = inf) or Coulomb friction at contact points on the top face, node by node or at Gauss
points of the top faces (:mod:`forward.contact_quadrature`), with the contact law of
:mod:`forward.coulomb_contact`.

In an increment the sphere's forces at the points are carried to the top nodes (N^T f) and taken
off the body's internal force, and their derivative (N^T df/dr N, cell by cell) off its tangent
(:meth:`PenaltyContact.add_to_system`). Each increment is solved by damped Newton with the points'
statuses held (:mod:`forward.penalty_newton`), re-solved until the statuses the solution calls for are those it was solved with
(:meth:`PenaltyContact.increment`); the statuses also follow the state in a solve's first Newton
iterations. The factorisation is of the tangent's symmetric part; the contact blocks that changed
since (points in or out, slip) are put back by a low-rank update (:meth:`PenaltyContact.correction`).
"""

from __future__ import annotations

import logging
import time

import numpy as np
import scipy.sparse as sp

from .contact_quadrature import cells_within, contact_points
from .coulomb_contact import FrictionContactState
from .coulomb_law import FREE
from .indenter_contact import IndenterContact
from .linear_solver import LinearSolveError, LowRankUpdate
from .newton import Equilibrium, IncrementFailed, NewtonSystem
from .penalty_newton import PenaltyNewton

__all__ = ["CONTACT_STATS", "PenaltyContact"]

log = logging.getLogger(__name__)

#: A top node's contact block (its 3 x 3 share of the tangent) counts as changed since the
#: factorisation when it moved by more than this fraction of the node's penalty: a node that came
#: into contact, left it, or slips (EmbeddedSolver._contact_correction).
CONTACT_BLOCK_CHANGE = 1e-3
#: A penalty contact point changes status only where that changes its force by more than this
#: fraction of the indenter's force (EmbeddedSolver._status_tolerance).
STATUS_FORCE_FRACTION = 1e-7
#: From this contact pass of an increment on, a penalty contact point may come into contact but
#: not leave it (a set that wanders without repeating itself otherwise never settles). Where a
#: point at the contact's edge toggles (held, it is pulled; released, it presses in), each pass
#: repeats the same Newton cycle until this pass keeps it: contact-L3, R = 4.77 mm, {10, 350} kPa,
#: the stick, 7 to 7.5 mm: four passes of ten Newton steps each, a third of the run's CG
#: iterations. With 2 instead of 4: Newton 250 -> 210, CG iterations 1,785 -> 1,437, the forces
#: within 1e-8 (the same point kept); no change where no set wanders past its first pass
#: (docs/validation/solver-and-speed.md, "A contact edge that toggles").
HOLDING_PASS = 2

#: The contact's counters in its solver's ``stats``: its forces and tangent blocks evaluated
#: (``contact_updates``: one per assembly in an increment, within ``assembly_s``), the low-rank
#: corrections made (their inverse columns' back-substitutions within), the statuses checked within
#: Newton solves and changed, the turning points' re-solves, the damped steps' trial states and
#: halvings, the Newton solves failed as stalled (forward.penalty_newton.STALL_STEPS).
CONTACT_STATS: dict[str, float] = {
    "contact_updates": 0,
    "contact_update_s": 0.0,
    "contact_corrections": 0,
    "contact_correction_s": 0.0,
    "status_checks": 0,
    "status_changes": 0,
    "status_s": 0.0,
    "turning_rounds": 0,
    "step_trials": 0,
    "step_halvings": 0,
    "stalled_solves": 0,
}


class PenaltyContact(PenaltyNewton, IndenterContact):
    """Stick or Coulomb friction by a penalty at contact points (module docstring).

    Parameters
    ----------
    solver : NewtonSystem
        The solver it belongs to (forward.solver.EmbeddedSolver); its spec's ``contact`` says
        the friction, the penalty and where the points are.
    """

    def __init__(self, solver: NewtonSystem) -> None:
        super().__init__(solver)
        spec = solver.spec.contact
        for key, zero in CONTACT_STATS.items():
            solver.stats.setdefault(key, zero)
        #: Coulomb's mu, or None for stick (mu = inf)
        self.friction = spec.friction
        self.parameters = ("c1", "c5") if spec.friction is None else ("c1", "c5", "mu")
        #: the slip tangent is unsymmetric (GMRES); the stick's is symmetric (CG)
        self.symmetric = spec.friction is None
        self._points = contact_points(solver.mesh, spec.integration, order=spec.order)
        self._contact_eps = spec.penalty * self._points.area  # mN/mm per point
        self._cell_eps = self._points.cell_scale(self._contact_eps)
        self._cell_slots = self._points.slots(solver.pattern, solver.top)
        #: its cells' blocks in the tangent (nc, k, 3, k, 3) at the last assembly, and
        #: (symmetrised) in the factorisation in hand
        self._contact_blocks: np.ndarray | None = None
        self._factored_contact_blocks: np.ndarray | None = None
        #: the last correction with the blocks and the factorisation count it was made for
        self._correction: tuple[np.ndarray, int, LowRankUpdate | None] | None = None
        #: the state of the increment being solved (its forces and tangent enter the system),
        #: None outside an increment
        self._state: FrictionContactState | None = None
        self._depth = 0.0
        #: the longest step a Newton step may take under the stick (mm; None: no limit)
        self._step_limit: float | None = None
        #: late in an increment's contact passes, points may come into contact but not leave it
        self._holding = False

    # ------------------------------------------------------------------ the interface
    def start(self) -> FrictionContactState:
        s = self.solver
        return FrictionContactState(
            s.sphere,
            self._points.xyz0,
            self._contact_eps,
            np.inf if self.friction is None else self.friction,
            n_params=len(self.parameters),
        )

    def add_to_system(self, u: np.ndarray, R: np.ndarray, K: sp.csr_matrix | None) -> None:
        if self._state is None:
            return
        t = time.perf_counter()
        s, pts = self.solver, self._points
        resp = self._state.response(pts.to_points(u[s.top]), self._depth)
        R.reshape(-1, 3)[s.top] -= pts.to_nodes(resp.force)
        self._contact_blocks = -pts.cell_blocks(resp.df_dr)
        if K is not None:
            K.data += self.scatter_cells(self._contact_blocks)
        s.stats["contact_updates"] += 1
        s.stats["contact_update_s"] += time.perf_counter() - t

    def for_factorisation(self, K: sp.csr_matrix) -> sp.csr_matrix:
        if self._contact_blocks is None:
            return K
        contact = self._contact_blocks
        symmetric = 0.5 * (contact + contact.transpose(0, 3, 4, 1, 2))
        self._factored_contact_blocks = symmetric
        if self.symmetric:
            return K
        K = K.copy()
        K.data += self.scatter_cells(symmetric - contact)
        return K

    def quarter_force(self, eq: Equilibrium, state: FrictionContactState) -> float:
        return -float(np.sum(state.force[:, 2]))

    def quarter_force_sensitivity(
        self, eq: Equilibrium, state: FrictionContactState, du_dtheta: np.ndarray
    ) -> np.ndarray:
        return -state.dforce[:, 2].sum(axis=0)

    def node_status(self, state: FrictionContactState) -> tuple[np.ndarray, np.ndarray]:
        return self._points.any_per_node(state.attached), self._points.any_per_node(state.slipping)

    def describe(self) -> str:
        c = self.solver.spec.contact
        if c.integration == "node":
            where = f"node-to-surface penalty ({c.penalty:g} kPa/mm by tributary area)"
        else:
            where = (
                f"surface-to-surface penalty ({c.penalty:g} kPa/mm at {c.order}x{c.order} Gauss points "
                "per top face)"
            )
        law = "stick (mu = inf)" if c.friction is None else f"Coulomb friction mu = {c.friction:g}"
        return f"rigid sphere, {where}, {law} (return map from anchors)"

    # ------------------------------------------------------------------ its numerics
    def scatter_cells(self, blocks: np.ndarray) -> np.ndarray:
        """The contact cells' blocks summed into a CSR data array of the body's pattern.

        Parameters
        ----------
        blocks : ndarray, shape (nc, k, 3, k, 3)
            A block per contact cell.

        Returns
        -------
        ndarray, shape (nnz,)
        """
        s = self.solver
        return np.bincount(self._cell_slots.ravel(), weights=blocks.ravel(), minlength=s.pattern.nnz)

    def correction(self, cmask: np.ndarray) -> LowRankUpdate | None:
        # the interface's correction: the changed cells' blocks, the largest first, as many cells as
        # their distinct dofs fit in the columns the factorisation keeps (``max_extra``)
        s = self.solver
        if (
            self._contact_blocks is None
            or self._factored_contact_blocks is None
            or s.linear.factor_mask is None
        ):
            return None
        made = self._correction  # the same blocks and factorisation: the same correction
        if made is not None and made[0] is self._contact_blocks and made[1] == s.stats["factorizations"]:
            return made[2]
        t = time.perf_counter()
        update = self._update(cmask)
        self._correction = (self._contact_blocks, s.stats["factorizations"], update)
        s.stats["contact_corrections"] += int(update is not None)
        s.stats["contact_correction_s"] += time.perf_counter() - t
        return update

    def _update(self, cmask: np.ndarray) -> LowRankUpdate | None:
        """:meth:`correction` made anew."""
        s = self.solver
        change = self._contact_blocks - self._factored_contact_blocks
        size = np.abs(change).max(axis=(1, 2, 3, 4)) / self._cell_eps
        cells = np.flatnonzero(size > CONTACT_BLOCK_CHANGE)
        if cells.size == 0:
            return None
        all_dofs = self._points.cell_dofs(s.top)
        if 3 * all_dofs.shape[1] * cells.size > s.linear.max_extra:
            # the largest changes first, as many cells as their distinct dofs fit in the columns
            by_size = cells[np.argsort(-size[cells], kind="stable")]
            cells = np.sort(by_size[: cells_within(all_dofs[by_size], s.linear.max_extra)])
        cell_dofs = all_dofs[cells]  # (m, k, 3)
        dofs, local = np.unique(cell_dofs, return_inverse=True)
        local = local.reshape(cell_dofs.shape)
        rows = np.broadcast_to(local[:, :, :, None, None], change[cells].shape)
        cols = np.broadcast_to(local[:, None, None, :, :], change[cells].shape)
        D = np.zeros((dofs.size, dofs.size))  # the changed cells' blocks, summed where they share nodes
        np.add.at(D, (rows.ravel(), cols.ravel()), change[cells].ravel())
        held = cmask[dofs]  # supports and symmetry planes stay eliminated
        D[held, :] = 0.0
        D[:, held] = 0.0
        return LowRankUpdate(s.linear, dofs, D)

    @property
    def has_a_last_resort(self) -> bool:
        """With friction: ``FRICTION_NEWTON`` lifted to ``STICK_NEWTON`` (the interface's).

        Returns
        -------
        bool
        """
        return self.friction is not None

    def increment(
        self,
        u: np.ndarray,
        u_pred: np.ndarray,
        d0: float,
        d1: float,
        state: FrictionContactState,
        du_start: np.ndarray | None,
        du_pred: np.ndarray | None = None,
    ) -> tuple[Equilibrium, FrictionContactState, int, int, np.ndarray | None]:
        # the interface's increment: Newton solves with the sphere's penalty forces in the
        # residual and each point's status held, until the statuses the solution calls for are
        # those it was solved with; then the anchors of slipping points move (settle)
        s = self.solver
        c = state.copy()
        top = s.top
        at_points = self._points.to_points
        s0_top = at_points(du_start[top]) if du_start is not None else None
        sp_top = at_points(du_pred[top]) if du_pred is not None else None
        c.anchor_newcomers(at_points(u[top]), d0, at_points(u_pred[top]), d1, s0_top, sp_top)
        tol = 1e-9 * s.sphere.radius
        c.status = c.settled_status(at_points(u_pred[top]), d1, tol)
        cmask = s.bc_fixed.ravel()
        trial, iters = u_pred, 0
        self._state, self._depth, self._holding = c, d1, False
        self._limit_steps(d0, d1)
        try:
            for passes in range(1, s.spec.solver.max_contact_passes + 1):
                eq = self.equilibrate(trial, cmask)
                iters += eq.iterations
                trial = eq.u
                wanted = c.settled_status(at_points(eq.u[top]), d1, self._status_tolerance(c, eq.u))
                log.debug(
                    "friction pass %d: %d come into contact, %d leave it",
                    passes,
                    int(((wanted != FREE) & (c.status == FREE)).sum()),
                    int(((wanted == FREE) & (c.status != FREE)).sum()),
                )
                if np.array_equal(wanted, c.status):
                    break
                # the set wanders or cycles (a set seen before can only come back from the second
                # pass, where HOLDING_PASS starts): from now on nothing leaves
                self._holding = passes >= HOLDING_PASS
                if self._holding:
                    wanted = np.maximum(wanted, c.status)
                    if np.array_equal(wanted, c.status):
                        log.debug("friction pass %d: contact set cycles; kept the nodes it holds", passes)
                        break
                c.status = wanted
            else:
                raise IncrementFailed("the contact set did not settle")
            try:
                sens = self._sensitivity(eq, cmask, c) if s.want_sensitivities else None
            except LinearSolveError as exc:  # an increment that fails, cut back like any other
                raise IncrementFailed(str(exc)) from exc
        finally:
            self._state = None
        c.settle(at_points(eq.u[top]), d1, at_points(sens[top]) if sens is not None else None)
        return eq, c, iters, passes, sens

    def _status_tolerance(self, contact: FrictionContactState, u: np.ndarray) -> np.ndarray:
        """How far (mm) each contact point may be inside the sphere while free, or outside its
        anchor's plane while held, before its status changes: the gap at which its penalty force
        is ``STATUS_FORCE_FRACTION`` of the indenter's force (at least 1e-9 R). A point at the
        contact's edge whose force is that small otherwise toggles from pass to pass."""
        s = self.solver
        resp = contact.response(self._points.to_points(u[s.top]), self._depth)
        total = max(float(np.abs(resp.pressure).sum()), s.force_scale)
        return np.maximum(1e-9 * s.sphere.radius, STATUS_FORCE_FRACTION * total / self._contact_eps)

    def _sensitivity(self, eq: Equilibrium, cmask: np.ndarray, contact: FrictionContactState) -> np.ndarray:
        """d u / d theta (n, 3, p) for theta = (c1, c5, mu) (p = 3) of a converged frictional
        state, or (c1, c5) (p = 2) of the penalty stick: (K - df/du) du = -dR/dtheta + (d f /
        d theta at fixed positions: the anchors' history and mu), solved by Krylov on the exact
        tangent preconditioned with the factorisation in hand, or by factorising it."""
        s = self.solver
        pts, n_p = self._points, contact.n_params
        resp = contact.response(pts.to_points(eq.u[s.top]), self._depth)
        b = np.zeros((s.n_dofs, n_p))
        b[:, :2] = -eq.dR
        explicit = contact.explicit_force_derivative(resp, n_p)  # (points, 3, p)
        b.reshape(-1, 3, n_p)[s.top] += pts.to_nodes(explicit)
        b[cmask] = 0.0
        x = s.sensitivity_solve(eq.K, cmask, b)
        return x.reshape(-1, 3, n_p)
