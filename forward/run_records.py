"""What a run of the embedded solver carries from increment to increment and what it keeps step by
step (:mod:`forward.solver`; docs/architecture.md, "forward").

:class:`IncrementState` is where the run stands between two converged increments: the depth, the
displacement, the last increment (the next one's predictor extrapolates it), the contact's state
and the sensitivities. :class:`RunRecords` are the per-step records a
:class:`~forward.result.SimulationResult` is made from. Both are written to the run's checkpoint
(:mod:`forward.checkpoint`) under the keys a checkpoint has always had, so that a run stopped by one
version of this module is resumed by the next.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

__all__ = ["CONVERGENCE_RECORDS", "STEP_COUNTS", "IncrementState", "RunRecords"]

#: What a step's increments count (forward.protocol_step.ProtocolSteps._step).
STEP_COUNTS = ("newton_iterations", "increments", "cutbacks", "contact_passes")
#: The convergence record's per-step counts that every run keeps (its wall time beside them, and
#: with friction the slipping nodes; the solver's counters per step where it counts them).
CONVERGENCE_RECORDS = (*STEP_COUNTS, "attached_nodes")

_STATE_KEYS = ("u", "last_inc", "last_dd", "contact", "du_dtheta", "last_dinc")
_RECORD_KEYS = ("depths", "forces", "disp", "f_sens", "u_sens", "status", "full", "conv")


@dataclass(frozen=True)
class IncrementState:
    """Where a run stands after a converged increment (module docstring).

    Parameters
    ----------
    depth : float
        The indenter's depth, mm.
    u : ndarray, shape (n, 3)
        Every node's displacement, mm.
    last_inc : ndarray, shape (n, 3)
        The displacement's change over the last increment.
    last_dd : float
        That increment's depth, mm (0 before the first).
    contact : object
        The contact's state (:meth:`forward.indenter_contact.IndenterContact.start`).
    du_dtheta, last_dinc : ndarray, shape (n, 3, p), or None
        The displacement's sensitivities and their change over the last increment (None: a run
        without sensitivities).
    """

    depth: float
    u: np.ndarray
    last_inc: np.ndarray
    last_dd: float
    contact: Any
    du_dtheta: np.ndarray | None = None
    last_dinc: np.ndarray | None = None

    @classmethod
    def start(cls, n_nodes: int, contact: Any, n_params: int, *, sensitivities: bool) -> IncrementState:
        """The undeformed body at depth 0.

        Parameters
        ----------
        n_nodes : int
            The mesh's nodes.
        contact : object
            The contact's starting state.
        n_params : int
            The sensitivities' parameters (c1, c5, and mu with friction).
        sensitivities : bool
            Whether the run carries sensitivities.

        Returns
        -------
        IncrementState
        """
        zeros = np.zeros((n_nodes, 3, n_params)) if sensitivities else None
        return cls(0.0, np.zeros((n_nodes, 3)), np.zeros((n_nodes, 3)), 0.0, contact, zeros, zeros)

    @classmethod
    def from_checkpoint(cls, saved: dict, depth: float) -> IncrementState:
        """The state a checkpoint holds, at ``depth`` (its last whole step's or its last increment's).

        Parameters
        ----------
        saved : dict
            The checkpoint's state (:func:`forward.checkpoint.read_checkpoint`).
        depth : float
            The depth it was written at, mm.

        Returns
        -------
        IncrementState
        """
        return cls(depth, *(saved[k] for k in _STATE_KEYS))

    def checkpoint_fields(self) -> dict[str, Any]:
        """The state under the checkpoint's keys (its depth is the records' or the step's).

        Returns
        -------
        dict
        """
        return {k: getattr(self, k) for k in _STATE_KEYS}

    def predicted(self, dd: float) -> tuple[np.ndarray, np.ndarray | None]:
        """The next increment's starting displacement and sensitivities (the predictor).

        The last increment extrapolated to one of depth ``dd``.

        Parameters
        ----------
        dd : float
            The next increment's depth, mm.

        Returns
        -------
        u_pred : ndarray, shape (n, 3)
        du_pred : ndarray, shape (n, 3, p), or None
        """
        ratio = dd / self.last_dd if self.last_dd > 0 else 0.0
        u_pred = self.u + ratio * self.last_inc
        du_pred = None if self.du_dtheta is None else self.du_dtheta + ratio * self.last_dinc
        return u_pred, du_pred

    def advanced(
        self, dd: float, u: np.ndarray, contact: Any, du_dtheta: np.ndarray | None
    ) -> IncrementState:
        """The state after a converged increment of depth ``dd`` that ended at ``u``.

        Parameters
        ----------
        dd : float
            The increment's depth, mm.
        u : ndarray, shape (n, 3)
            Its converged displacement.
        contact : object
            Its contact state.
        du_dtheta : ndarray, shape (n, 3, p), or None
            Its sensitivities.

        Returns
        -------
        IncrementState
        """
        last_dinc = None if du_dtheta is None else du_dtheta - self.du_dtheta
        return replace(
            self,
            depth=self.depth + dd,
            u=u,
            last_inc=u - self.u,
            last_dd=dd,
            contact=contact,
            du_dtheta=du_dtheta,
            last_dinc=last_dinc,
        )


@dataclass
class RunRecords:
    """A run's records, one entry a step from depth 0 on (module docstring).

    Parameters
    ----------
    depths, forces : list of float
        The depth (mm) and the whole specimen's force (mN).
    disp : list of ndarray, shape (nt, 3)
        The top nodes' displacements.
    f_sens, u_sens : list of ndarray
        The force's (p,) and the top displacements' (nt, 3, p) sensitivities (zeros without).
    status : list of ndarray of int8, shape (nt,)
        The top nodes' contact statuses (0 free, 1 attached, 2 slipping).
    full : list of ndarray, shape (n, 3), or None
        Every node's displacement, where the run keeps it.
    conv : dict of str to list
        The convergence record (:data:`CONVERGENCE_RECORDS`, ``wall_s`` and the counters).
    """

    depths: list
    forces: list
    disp: list
    f_sens: list
    u_sens: list
    status: list
    full: list | None
    conv: dict

    @classmethod
    def start(cls, n_nodes: int, n_top: int, n_params: int, *, full_field: bool) -> RunRecords:
        """The records of depth 0: no force, no displacement.

        Parameters
        ----------
        n_nodes, n_top : int
            The mesh's nodes and its top nodes.
        n_params : int
            The sensitivities' parameters.
        full_field : bool
            Whether every node's displacement is kept.

        Returns
        -------
        RunRecords
        """
        conv: dict[str, list] = {k: [0] for k in CONVERGENCE_RECORDS}
        conv["wall_s"] = [0.0]
        return cls(
            depths=[0.0],
            forces=[0.0],
            disp=[np.zeros((n_top, 3))],
            f_sens=[np.zeros(n_params)],
            u_sens=[np.zeros((n_top, 3, n_params))],
            status=[np.zeros(n_top, np.int8)],
            full=[np.zeros((n_nodes, 3))] if full_field else None,
            conv=conv,
        )

    @classmethod
    def from_checkpoint(cls, saved: dict) -> RunRecords:
        """The records a checkpoint holds.

        Parameters
        ----------
        saved : dict
            The checkpoint's state.

        Returns
        -------
        RunRecords
        """
        return cls(*(saved[k] for k in _RECORD_KEYS))

    def checkpoint_fields(self) -> dict[str, Any]:
        """The records under the checkpoint's keys.

        Returns
        -------
        dict
        """
        return {k: getattr(self, k) for k in _RECORD_KEYS}

    @property
    def steps_done(self) -> int:
        """The whole steps recorded (depth 0 is not one)."""
        return len(self.depths) - 1

    def add_step(
        self,
        depth: float,
        force: float,
        u: np.ndarray,
        top: np.ndarray,
        *,
        counts: dict[str, int],
        status: np.ndarray,
        attached_nodes: int,
        slipping_nodes: int | None,
        counters: dict[str, float],
        wall_s: float,
        f_sens: np.ndarray | None = None,
        u_sens: np.ndarray | None = None,
    ) -> None:
        """Record a whole step.

        Parameters
        ----------
        depth, force : float
            Its depth (mm) and the whole specimen's force (mN).
        u : ndarray, shape (n, 3)
            Every node's displacement.
        top : ndarray of int
            The top nodes.
        counts : dict
            Its Newton iterations, increments, cut-backs and contact passes.
        status : ndarray of int8, shape (nt,)
            The top nodes' contact statuses.
        attached_nodes : int
            How many top nodes the indenter holds.
        slipping_nodes : int or None
            With friction, how many slip.
        counters : dict
            The solver's counters over the step.
        wall_s : float
            Its wall time, s.
        f_sens, u_sens : ndarray or None, optional
            The force's and the top displacements' sensitivities.
        """
        self.depths.append(depth)
        self.forces.append(force)
        self.disp.append(u[top].copy())
        if self.full is not None:
            self.full.append(u.copy())
        if f_sens is not None:
            self.f_sens.append(f_sens)
            self.u_sens.append(u_sens)
        for key, val in counts.items():
            self.conv[key].append(val)
        self.conv["attached_nodes"].append(attached_nodes)
        self.status.append(status)
        if slipping_nodes is not None:
            self.conv.setdefault("slipping_nodes", [0]).append(slipping_nodes)
        for key, val in counters.items():  # (a checkpoint of before they were kept: 0 before)
            self.conv.setdefault(key, [0] * len(self.conv["wall_s"])).append(val)
        self.conv["wall_s"].append(wall_s)

    def keep_whole_steps(self) -> None:
        """Drop what a step stopped part way left (the wall time is appended last of a step's records)."""
        done = len(self.conv["wall_s"])
        for seq in (
            self.depths,
            self.forces,
            self.disp,
            self.f_sens,
            self.u_sens,
            self.status,
            *self.conv.values(),
        ):
            del seq[done:]
        if self.full is not None:
            del self.full[done:]
