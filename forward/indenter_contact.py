"""The one interface through which the embedded solver meets the indenter's contact.

The solver's driver (:meth:`forward.solver.EmbeddedSolver.run`) knows nothing of how a contact
is imposed: it asks the contact for a fresh state (:meth:`IndenterContact.start`), has it solve
each increment (:meth:`IndenterContact.increment`, which calls the solver's Newton machinery of
:mod:`forward.newton`), and reads the indenter force, its sensitivities and the top nodes'
statuses from it. While an increment is solved the contact adds its forces and tangent to the
body's (:meth:`IndenterContact.add_to_system`) and says what the factorisation of the tangent
leaves out (:meth:`IndenterContact.for_factorisation`, :meth:`IndenterContact.correction`).

Two contacts implement it: :class:`forward.node_stick.NodeStickContact` (the exact node-wise
stick, by constraints) and :class:`forward.penalty_contact.PenaltyContact` (stick or Coulomb
friction by a penalty, node by node or integrated over the top faces).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.sparse as sp

if TYPE_CHECKING:
    from .linear_solver import LowRankUpdate
    from .newton import Equilibrium, NewtonSystem

__all__ = ["IndenterContact"]


class IndenterContact(ABC):
    """A contact between the rigid sphere and the block's top face (module docstring).

    Attributes
    ----------
    solver : NewtonSystem
        The solver it belongs to (forward.solver.EmbeddedSolver) (its mesh, sphere, linear steps and Newton solve).
    parameters : tuple of str
        The parameters its sensitivities are taken for: ("c1", "c5"), and "mu" with friction.
    symmetric : bool
        Whether the tangent stays symmetric with this contact (CG; else GMRES).
    last_resort : bool
        Set by the driver while it makes a step again from its start before the run fails (its
        increments failed down to the smallest size), where the contact has a last resort
        (:attr:`has_a_last_resort`).
    """

    parameters: tuple[str, ...]
    symmetric: bool
    last_resort: bool = False

    @property
    def has_a_last_resort(self) -> bool:
        """Whether the contact solves an increment differently as a last resort.

        A limit it keeps for speed, lifted (:class:`forward.penalty_contact.PenaltyContact` with
        friction); none here.

        Returns
        -------
        bool
        """
        return False

    def __init__(self, solver: NewtonSystem) -> None:
        self.solver = solver

    @abstractmethod
    def start(self) -> Any:
        """The contact state before the first increment (nothing touches).

        Returns
        -------
        object
            The state :meth:`increment` takes and returns.
        """

    @abstractmethod
    def increment(
        self,
        u: np.ndarray,
        u_pred: np.ndarray,
        d0: float,
        d1: float,
        state: Any,
        du_start: np.ndarray | None,
        du_pred: np.ndarray | None = None,
    ) -> tuple[Equilibrium, Any, int, int, np.ndarray | None]:
        """Solve the increment from depth ``d0`` to ``d1``, starting from the prediction ``u_pred``.

        Parameters
        ----------
        u, u_pred : ndarray, shape (n, 3)
            The converged displacements at ``d0`` and the predicted ones at ``d1``.
        d0, d1 : float
            Indenter depths, mm.
        state : object
            The contact state at ``d0`` (left unchanged).
        du_start, du_pred : ndarray, shape (n, 3, p), optional
            d u / d theta at ``d0`` and predicted at ``d1``, when sensitivities are asked for.

        Returns
        -------
        tuple
            The equilibrium at ``d1``, the new contact state, Newton iterations, contact passes
            and (with sensitivities) d u / d theta (n, 3, p).

        Raises
        ------
        forward.newton.IncrementFailed
            When the increment does not converge (the driver cuts it back).
        """

    @abstractmethod
    def add_to_system(self, u: np.ndarray, R: np.ndarray, K: sp.csr_matrix | None) -> None:
        """Take the indenter's forces off the internal force and their derivative off the tangent.

        In place, while an increment is solved (nothing outside one).

        Parameters
        ----------
        u : ndarray, shape (n, 3)
            Displacements.
        R : ndarray, shape (3n,)
            The body's internal force at ``u``.
        K : scipy.sparse.csr_matrix or None
            The body's tangent at ``u`` (None: the residual only).
        """

    @abstractmethod
    def for_factorisation(self, K: sp.csr_matrix) -> sp.csr_matrix:
        """The matrix to factorise for a tangent (its symmetric part where the tangent is not symmetric).

        Parameters
        ----------
        K : scipy.sparse.csr_matrix
            The tangent.

        Returns
        -------
        scipy.sparse.csr_matrix
        """

    @abstractmethod
    def correction(self, cmask: np.ndarray) -> LowRankUpdate | None:
        """What turns the factorisation in hand into the tangent now (contact blocks changed since).

        Parameters
        ----------
        cmask : ndarray of bool, shape (3n,)
            The dofs held (eliminated) in the solve.

        Returns
        -------
        LowRankUpdate or None
            None when nothing changed (or the contact needs none).
        """

    @abstractmethod
    def quarter_force(self, eq: Equilibrium, state: Any) -> float:
        """The indenter force on the quarter model at a converged state.

        Parameters
        ----------
        eq : Equilibrium
            The converged state.
        state : object
            The contact state it was solved with.

        Returns
        -------
        float
            mN (x 4 for the whole specimen).
        """

    @abstractmethod
    def quarter_force_sensitivity(self, eq: Equilibrium, state: Any, du_dtheta: np.ndarray) -> np.ndarray:
        """The derivative of the quarter model's indenter force with respect to theta.

        Parameters
        ----------
        eq : Equilibrium
            The converged state (with its tangent and dR/dtheta).
        state : object
            The contact state it was solved with.
        du_dtheta : ndarray, shape (n, 3, p)
            The state's d u / d theta.

        Returns
        -------
        ndarray, shape (p,)
            mN per unit of each parameter.
        """

    @abstractmethod
    def node_status(self, state: Any) -> tuple[np.ndarray, np.ndarray]:
        """The top nodes in contact and those slipping.

        Parameters
        ----------
        state : object
            A contact state.

        Returns
        -------
        tuple of ndarray of bool, shape (nt,)
            In contact, slipping.
        """

    @abstractmethod
    def describe(self) -> str:
        """One line for the result file's ``solver.contact``.

        Returns
        -------
        str
        """
