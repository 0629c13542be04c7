"""The damped Newton solve of an increment under the penalty contact (:mod:`forward.penalty_contact`):
Newton-Raphson with the sphere's forces in the residual and the contact points' statuses held
(following the state in the first iterations), its corrections on the factorisation in hand, its
steps shortened (under the stick to a fraction of the increment's depth; with friction so that no
slipping point passes its anchor) and halved until the residual falls, and the turning points'
stick predicted (docs/architecture.md, "forward").

:class:`PenaltyNewton` is a base of :class:`forward.penalty_contact.PenaltyContact`, which holds the
state it reads (the increment's contact state, depth, points and step limit).
"""

from __future__ import annotations

import logging
import time

import numpy as np
import scipy.sparse as sp

from .linear_solver import LinearSolveError
from .linear_steps import KRYLOV_RTOL
from .material import InvertedElementError
from .newton import MAX_HALVINGS, MAX_STALE_STEPS, REFACTOR_RATIO, Equilibrium, IncrementFailed

__all__ = [
    "FRICTION_NEWTON",
    "STALL_DECREASE",
    "STALL_STEPS",
    "STATUS_NEWTON_UPDATES",
    "STICK_NEWTON",
    "STICK_STEP_LIMIT",
    "TURNING_ROUNDS",
    "PenaltyNewton",
]

log = logging.getLogger(__name__)

#: Under the penalty stick, each Newton solve takes at most this many damped steps
#: (:meth:`PenaltyNewton.equilibrate`); then the increment is cut back.
STICK_NEWTON = 60
#: With Coulomb friction, at most this many: an increment that has not converged by then is cut
#: back rather than driven on. At the hardest increments (many points slipping, the contact's
#: edge turning round) a Newton solve took 50 to 60 damped steps where its two halves take 10 to
#: 20 together: contact-L1, R = 4.77 mm, {3, 540} kPa, mu 0.3, CPU 41.5 -> 30.7 s, the forces
#: within 6e-4 of 60's, a third of the increments' own error (2e-3 against four increments a
#: step); nothing changes where no solve needs more (docs/validation/solver-and-speed.md,
#: "Friction's hard increments").
FRICTION_NEWTON = 20
# ... but a step whose increments fail down to the smallest size is made again from its start
# with ``STICK_NEWTON`` before the run fails (:attr:`IndenterContact.last_resort`): at R = 8 mm
# {1.498, 101.45} kPa, mu 0.383 (a fit's FE confirmation, contact-L1) the cap of 20 failed at
# 9.508 mm, the step's smallest increment, where 60 takes the run to 14 mm.
#: A penalty contact's statuses follow the state in the first this many Newton iterations of a
#: solve (PenaltyNewton._statuses_follow), then stay as they are until the solve ends.
STATUS_NEWTON_UPDATES = 8
#: Under the penalty stick a Newton step changes no displacement component by more than this
#: fraction of the increment's depth (longer steps are shortened to it; PenaltyNewton._damped_step). Below a
#: soft matrix whose fibers are slack in compression the tangent at a state far from
#: equilibrium can be nearly singular: steps of 100 to 900 mm were seen (c1 = 3, c5 = 540 kPa,
#: one stick point per face), each inverting elements at every halving. Not under friction, whose
#: equilibrium within an increment depends on the path to it (docs/validation/verification.md,
#: "The penalty and the points per face").
STICK_STEP_LIMIT = 0.2

#: With friction, a Newton solve whose Newton steps (each on the tangent at its state) lower the
#: residual by less than ``STALL_DECREASE`` ``STALL_STEPS`` times in a row has stalled, and fails
#: at once (the increment is cut back) instead of after ``FRICTION_NEWTON`` (or, in the last
#: resort, ``STICK_NEWTON``) iterations. Where it stalls, a point sits at its cone's edge and the
#: stick's and the slip's linearisations each send it to the other side: contact-L3, R = 4.77 mm,
#: {17.98, 210.5} kPa, mu 2.17 from 13.18 mm on, the residual stayed at 0.3834 of 500.8 mN (7.7
#: times the tolerance) for 60 Newton iterations at every increment down to 1/64 of a step, and
#: the run failed after 96 minutes on one step (docs/validation/solver-and-speed.md, "A point at
#: its cone's edge").
STALL_STEPS = 3
STALL_DECREASE = 0.01

#: How many times a Newton step is made again with more turning points' stick predicted
#: (:meth:`PenaltyNewton._turning_points_stick`): the new step can turn others round.
TURNING_ROUNDS = 4


class PenaltyNewton:
    """The increment's damped Newton solve of a penalty contact (module docstring)."""

    def _limit_steps(self, d0: float, d1: float) -> None:
        """Under the stick, no Newton step of the increment ``d0`` -> ``d1`` (mm) changes a
        displacement component by more than ``STICK_STEP_LIMIT`` of its depth; no limit with friction."""
        self._step_limit = STICK_STEP_LIMIT * abs(d1 - d0) if self.friction is None else None

    def equilibrate(self, u0: np.ndarray, cmask: np.ndarray) -> Equilibrium:
        """Damped Newton-Raphson to equilibrium with the contact's forces in the residual.

        Parameters
        ----------
        u0 : ndarray, shape (n, 3)
            The starting state.
        cmask : ndarray of bool, shape (3n,)
            The supports and symmetry planes (held at zero).

        Returns
        -------
        Equilibrium

        Raises
        ------
        forward.newton.IncrementFailed
            No convergence in ``STICK_NEWTON`` iterations (``FRICTION_NEWTON`` with friction,
            unless as the driver's last resort), a stalled solve with friction (``STALL_STEPS``),
            or an inverted element.

        Notes
        -----
        The frictional contact's forces in the residual
        (the supports in ``cmask`` held at zero), damped. As in :meth:`NewtonSystem.equilibrate`, corrections
        reuse the factorisation in hand while the residual contracts by at least
        ``REFACTOR_RATIO`` (``MAX_STALE_STEPS`` in a row at most), and take a Newton step with
        the tangent at the current state otherwise (:meth:`LinearSteps.newton_step`). Every step is
        shortened so that no slipping node passes its anchor
        (:meth:`FrictionContactState.step_fraction`); a Newton step is then halved until the
        residual falls (a full step can overshoot where a node slides along the indenter, with
        little but the body's shear stiffness to hold it, against the penalty's stiffness
        across), and a correction that does not lower it is replaced by a Newton step."""
        s = self.solver
        opts = s.spec.solver
        u = u0.reshape(-1).copy()
        s.begin_newton_solve()
        try:
            R, K, _ = s.assemble(u.reshape(-1, 3))
        except InvertedElementError as exc:
            raise IncrementFailed(str(exc)) from exc
        last, stale_steps, fresh_step, exact = np.inf, MAX_STALE_STEPS, True, False
        stalls = 0  # Newton steps in a row that lowered the residual by less than STALL_DECREASE
        max_steps = STICK_NEWTON if self.friction is None or self.last_resort else FRICTION_NEWTON
        for it in range(1, max_steps + 1):
            norm = np.linalg.norm(np.where(cmask, 0.0, R))
            ref = max(np.linalg.norm(R[cmask]), s.force_scale)
            log.debug("newton %d: residual %.3e of %.3e", it, norm, ref)
            at_round_off = fresh_step and norm > 0.5 * last and norm <= 1e-6 * ref  # no more to gain
            if norm <= opts.residual_tol * ref or at_round_off:
                K_out = dR = None
                if s.want_sensitivities:
                    _, K_out, dR = s.assemble(u.reshape(-1, 3), parameter_derivatives=True)
                return Equilibrium(u.reshape(-1, 3), R, K_out, it, dR)
            stalls = stalls + 1 if fresh_step and norm > (1.0 - STALL_DECREASE) * last else 0
            if self.friction is not None and stalls >= STALL_STEPS:
                s.stats["stalled_solves"] += 1
                raise IncrementFailed(
                    f"Newton stalled: {STALL_STEPS} Newton steps in a row lowered the residual by "
                    f"less than {STALL_DECREASE:.0%} (at {norm:.3g} mN, {norm / ref:.2g} of the "
                    f"reaction, after {it} iterations)"
                )
            r_free = np.where(cmask, 0.0, R)
            step = None
            worn = norm > REFACTOR_RATIO * last or stale_steps >= MAX_STALE_STEPS
            if not worn and s.linear.covers(cmask):  # a correction with the factorisation in hand
                try:
                    step = self._damped_step(u, s.solve(r_free, cmask), norm, cmask, halve=False)
                except LinearSolveError:
                    step = None
                stale_steps += 1
            fresh_step = step is None
            if fresh_step:  # a Newton step with the tangent here
                if K is None:
                    _, K, _ = s.assemble(u.reshape(-1, 3))
                rtol = self._krylov_rtol(norm, ref)
                try:
                    du = self._newton_direction(K, cmask, r_free, exact, rtol)
                    du = self._turning_points_stick(u, du, K, r_free, cmask, exact, rtol)
                except LinearSolveError as exc:
                    raise IncrementFailed(str(exc)) from exc
                step = self._damped_step(u, du, norm, cmask, halve=True)
                stale_steps = 0
            u, R = step
            exact = np.linalg.norm(np.where(cmask, 0.0, R)) >= norm
            K, last = None, norm
            if it <= STATUS_NEWTON_UPDATES and self._statuses_follow(u):
                # the residual with the statuses this state calls for; the next step is a Newton step
                R, _, _ = s.assemble(u.reshape(-1, 3), tangent=False)
                last, exact, stale_steps = np.inf, False, MAX_STALE_STEPS
        raise IncrementFailed(f"Newton did not converge in {max_steps} iterations")

    def _krylov_rtol(self, norm: float, ref: float) -> float:
        """The relative residual an inexact Newton step is solved to.

        ``KRYLOV_RTOL`` of the current residual under the stick (a constant forcing term: the
        step's error shrinks with the residual, as inexact Newton needs). With friction, as exact
        as the residual is far above the reactions (``KRYLOV_RTOL * ref / norm``): a slip step
        solved loosely there moves points across their stick zones and the friction flips. Under the
        stick that tightening bought nothing but failed Krylov solves: contact-L3, R = 4.77 mm,
        {3, 120} kPa, 6 steps: 20 of 73 Krylov solves failed and 21 factorisations were made; with
        the constant term 8 of 58 and 9, CPU 95.6 -> 59.1 s, forces the same to 2.3e-7
        (docs/validation/solver-and-speed.md, "Where the time goes").
        """
        if self.friction is None:
            return KRYLOV_RTOL
        return KRYLOV_RTOL * min(1.0, ref / norm)

    def _newton_direction(
        self, K: sp.csr_matrix, cmask: np.ndarray, r_free: np.ndarray, exact: bool, rtol: float
    ) -> np.ndarray:
        """The Newton step of the tangent ``K``: by a factorisation here when ``exact`` (the last
        step did not lower the residual), else inexact (the factorisation in hand preconditions
        a Krylov solve to ``rtol``)."""
        s = self.solver
        return s.fresh_step(K, cmask, r_free) if exact else s.newton_step(K, cmask, r_free, rtol)

    def _turning_points_stick(
        self,
        u: np.ndarray,
        du: np.ndarray,
        K: sp.csr_matrix,
        r_free: np.ndarray,
        cmask: np.ndarray,
        exact: bool,
        rtol: float,
    ) -> np.ndarray:
        """The Newton step ``du`` made again, if it takes slipping points past their anchors'
        planes (:meth:`FrictionContactState.turning`), with those points' response the stick's.

        A slipping point's tangent has no stiffness along its slip, so a step that turns it round
        overshoots the stick zone (mu p / eps wide) and the friction flips; cutting the whole step
        to the first anchor's plane (:meth:`FrictionContactState.step_fraction`) then leaves the
        rest of the mesh where it was, iteration after iteration. Predicting that the turning
        points stick (an active-set step, as a semi-smooth Newton method takes) puts them near
        their anchors and the rest where that calls for. The prediction enters only this step's
        system: the residual that accepts the step and decides convergence is the physics'.
        Only the contact's part of the tangent ``K`` and of the residual ``r_free`` (both at
        ``u``) changes: the body is not assembled again.
        """
        s = self.solver
        c, top, pts = self._state, s.top, self._points
        if c is None or c.mu == 0.0 or np.isinf(c.mu):
            return du
        at = pts.to_points(u.reshape(-1, 3)[top])
        law = c.response(at, self._depth)
        law_blocks = -pts.cell_blocks(law.df_dr)  # the contact's blocks in K
        stuck = np.zeros(at.shape[0], bool)
        for _ in range(TURNING_ROUNDS):
            turning = c.turning(at, pts.to_points(-du.reshape(-1, 3)[top]), self._depth) & ~stuck
            if not turning.any():
                break
            stuck |= turning
            s.stats["turning_rounds"] += 1
            log.debug("  %d slipping points turn round: their stick predicted", int(stuck.sum()))
            c.stuck = stuck
            try:
                predicted = c.response(at, self._depth)
            finally:
                c.stuck = None
            # the tangent's contact blocks as an assembly would leave them (the corrections and
            # the factorisation read them)
            self._contact_blocks = -pts.cell_blocks(predicted.df_dr)
            K_stuck = K.copy()
            K_stuck.data += self.scatter_cells(self._contact_blocks - law_blocks)
            rhs = r_free.copy()
            rhs.reshape(-1, 3)[top] -= pts.to_nodes(predicted.force - law.force)
            du = self._newton_direction(K_stuck, cmask, np.where(cmask, 0.0, rhs), exact, rtol)
        return du

    def _statuses_follow(self, u: np.ndarray) -> bool:
        """Within a Newton solve, hold the contact statuses the state ``u`` calls for (a
        semi-smooth Newton step on the active set); whether they changed."""
        s = self.solver
        t = time.perf_counter()
        c = self._state
        top = u.reshape(-1, 3)[s.top]
        wanted = c.settled_status(
            self._points.to_points(top), self._depth, self._status_tolerance(c, u.reshape(-1, 3))
        )
        if self._holding:
            wanted = np.maximum(wanted, c.status)
        s.stats["status_checks"] += 1
        s.stats["status_s"] += time.perf_counter() - t
        if np.array_equal(wanted, c.status):
            return False
        c.status = wanted
        s.stats["status_changes"] += 1
        return True

    def _damped_step(
        self, u: np.ndarray, du: np.ndarray, norm: float, cmask: np.ndarray, halve: bool
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """The state ``u - alpha du`` and its residual, ``du`` first shortened so that no
        slipping node passes its anchor (:meth:`FrictionContactState.step_fraction`) and, under
        the stick, so that no displacement component changes by more than ``STICK_STEP_LIMIT``
        times the increment's depth: with ``halve``, alpha halved until the residual falls below ``norm`` (else the
        best trial); without, the whole step if it lowers the residual, else None."""
        s = self.solver
        c, top, pts = self._state, s.top, self._points
        du = du * c.step_fraction(
            pts.to_points(u.reshape(-1, 3)[top]), pts.to_points(-du.reshape(-1, 3)[top]), self._depth
        )
        longest = float(np.abs(du).max(initial=0.0))
        if self._step_limit is not None and longest > self._step_limit:
            du = du * (self._step_limit / longest)
        alpha, best = 1.0, None
        for trial_no in range(MAX_HALVINGS + 2 if halve else 1):
            s.stats["step_trials"] += 1
            s.stats["step_halvings"] += int(trial_no > 0)
            trial = u - alpha * du
            try:
                R_try, _, _ = s.assemble(trial.reshape(-1, 3), tangent=False)
            except InvertedElementError:
                alpha *= 0.5
                continue
            n_try = np.linalg.norm(np.where(cmask, 0.0, R_try))
            if best is None or n_try < best[0]:
                best = (n_try, trial, R_try)
            if n_try < norm:
                return trial, R_try
            alpha *= 0.5
        if not halve:
            return None
        if best is None:
            raise IncrementFailed("every Newton step inverted an element")
        return best[1], best[2]
