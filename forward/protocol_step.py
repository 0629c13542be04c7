"""One protocol step of the embedded solver's run (paper 2.4.1: 28 steps of 0.5 mm): its
increments, halved where one fails and doubled after one converges, the step made again with the
contact's last resort before the run fails, and the step's record (docs/architecture.md,
"forward").

:class:`ProtocolSteps` is a base of :class:`forward.solver.EmbeddedSolver`, which drives the
steps, keeps the checkpoint and builds the result; the increments themselves are the contact's
(:meth:`forward.indenter_contact.IndenterContact.increment`).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from .newton import Equilibrium, IncrementFailed
from .result import SYMMETRY_FACTOR, SimulationResult
from .run_records import STEP_COUNTS, IncrementState, RunRecords

if TYPE_CHECKING:
    from .indenter_contact import IndenterContact
    from .spec import ModelSpec

__all__ = ["CUTBACK_BUDGET", "STEP_COUNTERS", "ProtocolSteps", "SimulationError"]

log = logging.getLogger(__name__)


class SimulationError(RuntimeError):
    """A simulation that could not reach its final depth; names the depth reached.

    Parameters
    ----------
    message : str
        What failed, where.
    depth_reached : float
        The last converged depth, mm.
    partial : SimulationResult or None, optional
        The steps finished before it failed (kept so that nothing computed is lost).
    """

    def __init__(self, message: str, depth_reached: float, partial: SimulationResult | None = None):
        super().__init__(message)
        self.depth_reached = depth_reached
        self.partial = partial


#: A step may fail this many times ``max_cutbacks`` increments in all (halving and doubling back)
#: before the run is given up: a hard stretch (the composite's matrix pinched between the sphere
#: and a fiber) needs several small increments in a row, not one.
CUTBACK_BUDGET = 4
#: Counters of :attr:`EmbeddedSolver.stats` also recorded per step in the result's convergence
#: record (with the step's failed increments).
STEP_COUNTERS = ("assemblies", "factorizations", "krylov_iterations", "back_substitutions")


class ProtocolSteps:
    """The increments of one protocol step and its record (module docstring).

    :class:`forward.solver.EmbeddedSolver` sets the attributes below.

    Attributes
    ----------
    spec : ModelSpec
        The model (its protocol and the solver's cut-back limits).
    contact : IndenterContact
        The contact in use, which solves each increment.
    stats : dict
        The run's counters (``STEP_COUNTERS`` of them are recorded per step).
    top : ndarray of int
        The top surface's nodes.
    """

    spec: ModelSpec
    contact: IndenterContact
    stats: dict
    top: np.ndarray

    def _step(
        self,
        state: IncrementState,
        d_target: float,
        mid_step: dict | None,
        save: Callable[[IncrementState, dict | None], None],
        so_far: Callable[[], SimulationResult],
    ) -> tuple[IncrementState, Equilibrium, dict[str, int], dict[str, float], float]:
        """The increments of one protocol step to ``d_target`` from ``state`` (module docstring:
        halved where one fails, doubled after one converges, the step made again with the
        contact's last resort before the run fails), resumed from ``mid_step`` where a checkpoint
        stopped inside it. Returns the state at ``d_target``, its last equilibrium, the step's
        counts, the solver's counters at its start and its start time."""
        proto, opts = self.spec.protocol, self.spec.solver
        nominal = proto.step_size / opts.substeps
        t_step = time.perf_counter()
        counted = {key: self.stats[key] for key in STEP_COUNTERS}
        rec = dict.fromkeys(STEP_COUNTS, 0)
        inc = nominal
        if mid_step is not None:  # this step's increments before the stop count as its own
            inc, rec, counted = mid_step["increment"], mid_step["counters"], mid_step["stats_at_start"]
            t_step -= mid_step["step_s"]
        eq = None
        self.contact.last_resort, tried = False, 0
        step_start = state
        while state.depth < d_target - 1e-12:
            d = state.depth
            dd = min(inc, d_target - d)
            if d_target - (d + dd) < 1e-9 * proto.step_size:
                dd = d_target - d
            u_pred, du_pred = state.predicted(dd)
            try:
                eq, contact_new, its, passes, sens = self.contact.increment(
                    state.u, u_pred, d, d + dd, state.contact, state.du_dtheta, du_pred
                )
            except IncrementFailed as exc:
                log.debug("increment %.4g -> %.4g mm failed: %s", d, d + dd, exc)
                rec["cutbacks"] += 1
                smallest = dd <= nominal * 2.0**-opts.max_cutbacks * (1.0 + 1e-9)
                budget = CUTBACK_BUDGET * max(opts.max_cutbacks, 1)
                spent = smallest or rec["cutbacks"] - tried > budget
                if spent and self.contact.has_a_last_resort and not self.contact.last_resort:
                    # the step again from its start, the contact's limits for speed lifted
                    self.contact.last_resort, tried = True, rec["cutbacks"]
                    state, inc = step_start, nominal
                    continue
                if spent:
                    raise SimulationError(
                        f"simulation failed at depth {d + dd:.4g} mm (last converged {d:.4g} mm of "
                        f"{proto.max_depth:g}): {exc}",
                        depth_reached=d,
                        partial=so_far(),
                    ) from exc
                inc = dd / 2.0
                continue
            state = state.advanced(dd, eq.u, contact_new, sens)
            rec["newton_iterations"] += its
            rec["increments"] += 1
            rec["contact_passes"] += passes
            inc = min(nominal, 2.0 * inc)
            if state.depth < d_target - 1e-12:
                mid = {
                    "depth": state.depth,
                    "increment": inc,
                    "counters": dict(rec),
                    "stats_at_start": counted,
                    "step_s": time.perf_counter() - t_step,
                }
                save(state, mid)
        assert eq is not None
        return state, eq, rec, counted, t_step

    def _record_step(
        self,
        records: RunRecords,
        state: IncrementState,
        eq: Equilibrium,
        counts: dict[str, int],
        counted: dict[str, float],
        t_step: float,
    ) -> None:
        """Record the step that ended at ``state`` with equilibrium ``eq``."""
        contact = state.contact
        attached, slipping = self.contact.node_status(contact)
        f_sens = u_sens = None
        if state.du_dtheta is not None:
            f_sens = SYMMETRY_FACTOR * self.contact.quarter_force_sensitivity(eq, contact, state.du_dtheta)
            u_sens = state.du_dtheta[self.top].copy()
        records.add_step(
            state.depth,
            SYMMETRY_FACTOR * self.contact.quarter_force(eq, contact),
            state.u,
            self.top,
            counts=counts,
            status=attached.astype(np.int8) + slipping,
            attached_nodes=int(attached.sum()),
            slipping_nodes=int(slipping.sum()) if "mu" in self.contact.parameters else None,
            counters={key: self.stats[key] - was for key, was in counted.items()},
            wall_s=time.perf_counter() - t_step,
            f_sens=f_sens,
            u_sens=u_sens,
        )
