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
    """

    parameters: tuple[str, ...]
    symmetric: bool

    def __init__(self, solver: NewtonSystem) -> None:
        self.solver = solver

    @abstractmethod
    def start(self) -> Any:
        """The contact state before the first increment (nothing touches)."""

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
        """Solve the increment from depth ``d0`` (state ``u``, contact ``state``) to ``d1``,
        starting from the prediction ``u_pred``.

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
        """Take the indenter's forces at ``u`` (n, 3) off the internal force ``R`` (3n,) and
        their derivative off the tangent ``K`` (in place), while an increment is solved."""

    @abstractmethod
    def for_factorisation(self, K: sp.csr_matrix) -> sp.csr_matrix:
        """The matrix to factorise for the tangent ``K`` (its symmetric part where K is not)."""

    @abstractmethod
    def correction(self, cmask: np.ndarray) -> LowRankUpdate | None:
        """What turns the factorisation in hand into the tangent now (contact blocks changed
        since it was made), or None."""

    @abstractmethod
    def quarter_force(self, eq: Equilibrium, state: Any) -> float:
        """The indenter force on the quarter model at a converged state, mN."""

    @abstractmethod
    def quarter_force_sensitivity(self, eq: Equilibrium, state: Any, du_dtheta: np.ndarray) -> np.ndarray:
        """d (quarter force) / d theta (p,) at a converged state with d u / d theta (n, 3, p)."""

    @abstractmethod
    def node_status(self, state: Any) -> tuple[np.ndarray, np.ndarray]:
        """The top nodes in contact and those slipping (boolean arrays over the top nodes)."""

    @abstractmethod
    def describe(self) -> str:
        """One line for the result file's ``solver.contact``."""
