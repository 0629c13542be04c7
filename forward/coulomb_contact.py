"""Coulomb friction between the rigid spherical indenter and the block's top-surface nodes
(penalty, node to rigid surface): the contact points' statuses and anchors through the
increments. The law at each point, its derivatives and the indenter's surface are
:mod:`forward.coulomb_law`'s.

Within an increment's Newton solve the contact statuses are held, and no slipping node is stepped
past its anchor (:func:`forward.coulomb_law.anchor_crossing_step`); between solves they are settled until the state
is consistent. mu = 0 is frictionless; mu -> infinity is
stick by the penalty spring, which tends to :mod:`forward.stick_contact`'s exact stick as
``penalty`` grows (README, "Friction"). Every derivative the solver and its sensitivities need is
exact: of ``f`` with respect to the node's position, its anchor and mu (:func:`forward.coulomb_law.contact_response`),
and of the anchor's updates.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .coulomb_law import (
    FREE,
    ContactResponse,
    anchor_crossing_fractions,
    capsule_projection,
    contact_response,
    settled_status,
)
from .stick_contact import RigidSphere, anchor_derivative, path_meets_sphere


@dataclass
class FrictionContactState:
    """The contact points' statuses and anchors through a penalty contact's increments.

    Each point's contact status (FREE, CONTACT) and anchor (relative to the sphere's centre) with
    the anchor's derivatives (m, 3, p); at the end of an increment, the sphere's force on each
    point (and its derivative) and which points slip.

    Parameters
    ----------
    sphere : RigidSphere
        The indenter.
    top_xyz0 : ndarray, shape (m, 3)
        The contact points' reference positions (top nodes, or Gauss points of the top faces).
    eps : ndarray, shape (m,)
        Their penalties, mN/mm.
    mu : float
        Coulomb's friction coefficient (``inf``: stick).
    n_params : int, optional
        The parameters the anchors' derivatives are taken for (2: c1, c5; 3: and mu).
    """

    sphere: RigidSphere
    top_xyz0: np.ndarray  # (nt, 3) reference positions of the top nodes
    eps: np.ndarray  # (nt,) node penalties, mN/mm
    mu: float
    n_params: int = 3
    status: np.ndarray = field(init=False)
    anchor: np.ndarray = field(init=False)
    danchor: np.ndarray = field(init=False)
    #: the sphere's force on each node at the end of the last increment (nt, 3), and its
    #: derivative (nt, 3, p) when the increment had sensitivities
    force: np.ndarray = field(init=False)
    dforce: np.ndarray | None = field(init=False, default=None)
    #: the nodes slipping at the end of the last increment
    slipping: np.ndarray = field(init=False)
    #: points whose response a Newton step predicts as the stick's (:meth:`turning`); None
    #: (the physics) everywhere else, and always in a residual that decides convergence
    stuck: np.ndarray | None = field(init=False, default=None)

    def __post_init__(self) -> None:
        nt = self.top_xyz0.shape[0]
        self.status = np.full(nt, FREE, dtype=np.int8)
        self.anchor = np.zeros((nt, 3))
        self.danchor = np.zeros((nt, 3, self.n_params))
        self.force = np.zeros((nt, 3))
        self.slipping = np.zeros(nt, dtype=bool)

    def copy(self) -> FrictionContactState:
        """An independent copy (an increment works on one, kept only if it converges)."""
        other = FrictionContactState(self.sphere, self.top_xyz0, self.eps, self.mu, self.n_params)
        other.status = self.status.copy()
        other.anchor = self.anchor.copy()
        other.danchor = self.danchor.copy()
        other.force = self.force.copy()
        other.dforce = None if self.dforce is None else self.dforce.copy()
        other.slipping = self.slipping.copy()
        return other

    @property
    def attached(self) -> np.ndarray:
        """The nodes in contact (the name :class:`forward.stick_contact.StickContactState` uses)."""
        return self.status != FREE

    def relative(
        self, u_top: np.ndarray, depth: float, nodes: np.ndarray | slice = slice(None)
    ) -> np.ndarray:
        """Positions of contact points relative to the sphere's centre at a depth.

        Parameters
        ----------
        u_top : ndarray, shape (k, 3)
            The points' displacements (their rows of ``nodes``).
        depth : float
            The indenter's depth, mm.
        nodes : ndarray or slice, optional
            Which points.

        Returns
        -------
        ndarray, shape (k, 3)
        """
        return self.top_xyz0[nodes] + u_top - self.sphere.centre(depth)

    def anchor_newcomers(
        self,
        u_start: np.ndarray,
        depth_start: float,
        u_pred: np.ndarray,
        depth_end: float,
        du_start: np.ndarray | None = None,
        du_pred: np.ndarray | None = None,
    ) -> None:
        """Anchor every free point where its predicted path in the increment crosses the sphere.

        Used if it comes into contact in the increment.

        Parameters
        ----------
        u_start : ndarray, shape (m, 3)
            The points' displacements at the increment's start.
        depth_start : float
            The depth there, mm.
        u_pred : ndarray, shape (m, 3)
            Their predicted displacements at its end.
        depth_end : float
            The depth there, mm.
        du_start, du_pred : ndarray, shape (m, 3, p), optional
            Their derivatives with respect to theta (for the anchors' derivatives).
        """
        new = np.flatnonzero(self.status == FREE)
        if new.size == 0:
            return
        r0 = self.relative(u_start[new], depth_start, new)
        r1 = self.relative(u_pred[new], depth_end, new)
        a = path_meets_sphere(r0, r1, self.sphere.radius)
        shaft = a[:, 2] > 0.0  # past the equator: on the shaft, where the end point projects
        a_shaft, da_shaft = capsule_projection(r1[shaft], self.sphere.radius)
        a[shaft] = a_shaft
        self.anchor[new] = a
        if du_start is not None and du_pred is not None:
            d = anchor_derivative(r0, r1, a, du_start[new], du_pred[new])
            d[shaft] = da_shaft @ du_pred[new][shaft]
            self.danchor[new] = 0.0
            self.danchor[new, :, : d.shape[2]] = d

    def response(self, u_top: np.ndarray, depth: float) -> ContactResponse:
        """The indenter's force on the points, the statuses held (:func:`contact_response`).

        Parameters
        ----------
        u_top : ndarray, shape (m, 3)
            The points' displacements.
        depth : float
            The indenter's depth, mm.

        Returns
        -------
        ContactResponse
        """
        r = self.relative(u_top, depth)
        return contact_response(r, self.anchor, self.eps, self.mu, self.status, stuck=self.stuck)

    def settled_status(self, u_top: np.ndarray, depth: float, tol: float) -> np.ndarray:
        """The statuses a state calls for (:func:`settled_status`).

        Parameters
        ----------
        u_top : ndarray, shape (m, 3)
            The points' displacements.
        depth : float
            The indenter's depth, mm.
        tol : float or ndarray
            How far (mm) a point may be inside the sphere while free, or outside its anchor's
            plane while held.

        Returns
        -------
        ndarray, shape (m,)
        """
        r = self.relative(u_top, depth)
        return settled_status(r, self.anchor, self.sphere.radius, self.status, tol)

    def step_fraction(self, u_top: np.ndarray, step_top: np.ndarray, depth: float) -> float:
        """The largest fraction of a step that takes no slipping point past its anchor.

        Parameters
        ----------
        u_top : ndarray, shape (m, 3)
            The points' displacements.
        step_top : ndarray, shape (m, 3)
            Their step.
        depth : float
            The indenter's depth, mm.

        Returns
        -------
        float
            In (0, 1] (:func:`anchor_crossing_step`).
        """
        return float(self._crossing_fractions(u_top, step_top, depth).min(initial=1.0))

    def turning(self, u_top: np.ndarray, step_top: np.ndarray, depth: float) -> np.ndarray:
        """The slipping points that a step would take past their anchor's plane.

        There the friction turns round: they stick on the way (the stick zone is mu p / eps wide).

        Parameters
        ----------
        u_top : ndarray, shape (m, 3)
            The points' displacements.
        step_top : ndarray, shape (m, 3)
            Their step.
        depth : float
            The indenter's depth, mm.

        Returns
        -------
        ndarray of bool, shape (m,)
        """
        return self._crossing_fractions(u_top, step_top, depth) < 1.0

    def _crossing_fractions(self, u_top: np.ndarray, step_top: np.ndarray, depth: float) -> np.ndarray:
        """:func:`anchor_crossing_fractions` of the points slipping with a traction."""
        if self.mu == 0.0:  # no friction to turn round
            return np.ones(u_top.shape[0])
        resp = self.response(u_top, depth)
        rubbing = resp.slipping & (np.linalg.norm(resp.traction, axis=1) > 0.0)
        if not rubbing.any():
            return np.ones(u_top.shape[0])
        w = self.relative(u_top, depth) - self.anchor
        return anchor_crossing_fractions(w, resp.normal, step_top, rubbing)

    def settle(self, u_top: np.ndarray, depth: float, du_top: np.ndarray | None = None) -> None:
        """End an increment at a converged state.

        Records the indenter's force on each point (``force``) and its derivative (``dforce``,
        with ``du_top``); then points that slipped move their anchor to ``r + t / eps``
        projected on the surface (carrying the derivatives).

        Parameters
        ----------
        u_top : ndarray, shape (m, 3)
            The points' displacements.
        depth : float
            The indenter's depth, mm.
        du_top : ndarray, shape (m, 3, p), optional
            The converged state's derivatives with respect to theta.
        """
        resp = self.response(u_top, depth)
        r = self.relative(u_top, depth)
        slip = resp.slipping
        self.force = resp.force
        self.dforce = None
        elastic = r[slip] + resp.traction[slip] / self.eps[slip, None]
        moved, d_moved = capsule_projection(elastic, self.sphere.radius)
        if du_top is not None:
            self.dforce = self.force_derivative(resp, du_top)
            dt = self.traction_derivative(resp, du_top)
            self.danchor[slip] = d_moved @ (du_top[slip] + dt[slip] / self.eps[slip, None, None])
            self.danchor[~resp.active] = 0.0
        self.anchor[slip] = moved
        self.slipping = slip.copy()

    def _chain(self, d_dr: np.ndarray, d_da: np.ndarray, d_dmu: np.ndarray, du_top: np.ndarray) -> np.ndarray:
        """d (force or traction) / d theta (nt, 3, p) from its derivatives in the node's position,
        its anchor and mu, for node derivatives ``du_top`` (nt, 3, p); theta's last column is mu
        when p == 3."""
        p = du_top.shape[2]
        d = d_dr @ du_top + d_da @ self.danchor[:, :, :p]
        if p == 3:
            d[:, :, 2] += d_dmu
        return d

    def traction_derivative(self, resp: ContactResponse, du_top: np.ndarray) -> np.ndarray:
        """d t / d theta for the points' derivatives.

        Parameters
        ----------
        resp : ContactResponse
            The response at the state.
        du_top : ndarray, shape (m, 3, p)
            The points' d u / d theta.

        Returns
        -------
        ndarray, shape (m, 3, p)
        """
        return self._chain(resp.dt_dr, resp.dt_da, resp.dt_dmu, du_top)

    def force_derivative(self, resp: ContactResponse, du_top: np.ndarray) -> np.ndarray:
        """d f / d theta for the points' derivatives.

        Parameters
        ----------
        resp : ContactResponse
            The response at the state.
        du_top : ndarray, shape (m, 3, p)
            The points' d u / d theta.

        Returns
        -------
        ndarray, shape (m, 3, p)
        """
        return self._chain(resp.df_dr, resp.df_da, resp.dt_dmu, du_top)

    def explicit_force_derivative(self, resp: ContactResponse, n_params: int) -> np.ndarray:
        """The part of d f / d theta at fixed point positions (anchors' derivatives and mu).

        The right-hand side's contact part in the sensitivity solve.

        Parameters
        ----------
        resp : ContactResponse
            The response at the state.
        n_params : int
            p.

        Returns
        -------
        ndarray, shape (m, 3, p)
        """
        return self.force_derivative(resp, np.zeros((resp.force.shape[0], 3, n_params)))
