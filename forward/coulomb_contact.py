"""Coulomb friction between the rigid spherical indenter and the block's top-surface nodes
(penalty, node to rigid surface).

Each top node in contact has an **anchor** ``a`` on the indenter's surface (relative to the
sphere's centre, fixed in the indenter's frame): where it touched, or where it last slipped to.
Within an increment the node meets the indenter's tangent plane at its anchor (normal ``n``, the
surface's outward normal there): with ``w = r - a`` (``r`` the node's position relative to the
centre) the indenter's force on the node is

    f = p n + t,        p = -eps n.w                     (normal, pushing when p > 0)
    tau = -eps P w,     P = I - n n^T                    (the stick trial traction)
    t = tau                       if |tau| <= mu p       (stick: f = -eps w, a spring to the anchor)
    t = mu p tau / |tau|          otherwise              (slip, against the motion)

``eps`` is the penalty of each node: ``penalty`` (kPa per mm of penetration) times the node's
tributary area on the top face, so that a uniform pressure gives a uniform penetration (as
FEBio's surface-integrated penalty does). At the end of an increment a slipping node moves its
anchor to where its traction is elastic, ``r + t / eps`` projected on the surface, so the plane
follows the node; a node that leaves the indenter forgets its anchor. A node comes into contact
where its path in the increment crosses the sphere's lower hemisphere (as
:mod:`forward.stick_contact` attaches nodes, and as FEBio's indenter mesh is a hemisphere).

Why the tangent plane and not the sphere itself: with the sphere's normal at the node's current
position, the normal force turns as the node slides, a stiffness -p / R that on meshes of the
paper's size rivals the body's own at a node pressed by a few hundred mN, so that frictionless
and slipping nodes make Newton's tangent singular. The plane at the anchor differs from the
sphere by (slip in one increment)^2 / (2 R): under a micrometre for the protocol's increments, and
nothing for a node that sticks. Above its centre the sphere goes on as a shaft of the same radius
(:func:`capsule_axis_offset`), so that a node that slides up past the equator (deeper than R)
stays in contact.

Within an increment's Newton solve the contact statuses are held, and no slipping node is stepped
past its anchor (:func:`anchor_crossing_step`); between solves they are settled until the state
is consistent. mu = 0 is frictionless; mu -> infinity is
stick by the penalty spring, which tends to :mod:`forward.stick_contact`'s exact stick as
``penalty`` grows (README, "Friction"). Every derivative the solver and its sensitivities need is
exact: of ``f`` with respect to the node's position, its anchor and mu (:func:`contact_response`),
and of the anchor's updates.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .stick_contact import RigidSphere, anchor_derivative, path_meets_sphere

#: Contact status of a top node, held within an increment's Newton solve.
FREE, CONTACT = 0, 1


@dataclass
class ContactResponse:
    """The indenter's force on each top node and its derivatives (arrays over the top nodes)."""

    force: np.ndarray  # (nt, 3) f = p n + t
    traction: np.ndarray  # (nt, 3) t, the tangential (friction) part
    active: np.ndarray  # (nt,) held in contact
    slipping: np.ndarray  # (nt,) in contact and on the friction cone
    df_dr: np.ndarray  # (nt, 3, 3) d f / d r
    df_da: np.ndarray  # (nt, 3, 3) d f / d anchor
    dt_dr: np.ndarray  # (nt, 3, 3) d t / d r
    dt_da: np.ndarray  # (nt, 3, 3) d t / d anchor
    dt_dmu: np.ndarray  # (nt, 3) d t / d mu (= d f / d mu)
    pressure: np.ndarray  # (nt,) p, the normal force
    normal: np.ndarray  # (nt, 3) n, the indenter's normal at the anchor


def contact_response(
    r: np.ndarray,
    anchor: np.ndarray,
    eps: np.ndarray,
    mu: float,
    status: np.ndarray,
    stuck: np.ndarray | None = None,
) -> ContactResponse:
    """The indenter's force on contact points and its derivatives (module docstring).

    Vectorised over the points ("nodes" below: node-wise contact points, or Gauss points of the
    top faces). The cone is mu max(p, 0): a pulled point carries no friction rather than friction
    turned round.

    Parameters
    ----------
    r : ndarray, shape (m, 3)
        The points' positions relative to the sphere's centre.
    anchor : ndarray, shape (m, 3)
        Their anchors on the indenter's surface.
    eps : ndarray, shape (m,)
        Their penalties, mN/mm.
    mu : float
        Coulomb's friction coefficient (``inf``: stick).
    status : ndarray, shape (m,)
        Each point's status held (FREE or CONTACT); a point held in contact that has left its
        plane is pulled back (p < 0): what :func:`settled_status` releases.
    stuck : ndarray of bool, shape (m,), optional
        Points whose response is the stick's whatever their cone (the trial traction and its
        derivatives): a Newton step's prediction that a slipping point turning round sticks
        (:meth:`FrictionContactState.turning`), never a converged state's.

    Returns
    -------
    ContactResponse
        Forces, tractions, statuses and the derivatives with respect to the points' positions,
        their anchors and mu.
    """
    eye = np.eye(3)
    off, D = capsule_axis_offset(anchor)
    rho_a = np.linalg.norm(off, axis=1)
    safe_rho = np.where(rho_a > 0.0, rho_a, 1.0)
    n = off / safe_rho[:, None]
    P = eye - n[:, :, None] * n[:, None, :]
    dn_da = (P / safe_rho[:, None, None]) @ D
    active = status != FREE
    w = r - anchor
    nw = np.einsum("ij,ij->i", n, w)
    w_dn = np.einsum("ij,ijk->ik", w, dn_da)  # w^T dn/da
    p = np.where(active, -eps * nw, 0.0)
    dp_dr = -eps[:, None] * n
    dp_da = eps[:, None] * (n - w_dn)
    tau = -eps[:, None] * (w - n * nw[:, None])
    dtau_dr = -eps[:, None, None] * P
    dtau_da = eps[:, None, None] * (P + nw[:, None, None] * dn_da + n[:, :, None] * w_dn[:, None, :])

    size = np.linalg.norm(tau, axis=1)
    safe_size = np.where(size > 0.0, size, 1.0)
    tau_hat = tau / safe_size[:, None]
    pushed = p > 0.0
    cone_p = np.where(pushed, p, 0.0)
    stick = np.isinf(mu)  # mu = inf: stick by the penalty spring, no cone to reach
    cone = np.zeros_like(p) if stick else mu * cone_p
    slipping = active & (size > cone) & (size > 0.0) & ~stick
    if stuck is not None:
        slipping &= ~stuck
    s3, s33 = slipping[:, None], slipping[:, None, None]
    proj = (cone / safe_size)[:, None, None] * (eye - tau_hat[:, :, None] * tau_hat[:, None, :])
    grow = (0.0 if stick else mu) * pushed[:, None, None] * tau_hat[:, :, None]  # the cone grows with p
    dt_dr = np.where(s33, proj @ dtau_dr + grow * dp_dr[:, None, :], dtau_dr)
    dt_da = np.where(s33, proj @ dtau_da + grow * dp_da[:, None, :], dtau_da)
    traction = np.where(s3, cone[:, None] * tau_hat, tau)
    dt_dmu = np.where(s3, cone_p[:, None] * tau_hat, 0.0)

    a3, a33 = active[:, None], active[:, None, None]
    traction = np.where(a3, traction, 0.0)
    dt_dr = np.where(a33, dt_dr, 0.0)
    dt_da = np.where(a33, dt_da, 0.0)
    dt_dmu = np.where(a3, dt_dmu, 0.0)
    df_dr = np.where(a33, n[:, :, None] * dp_dr[:, None, :], 0.0) + dt_dr
    df_da = np.where(a33, n[:, :, None] * dp_da[:, None, :] + p[:, None, None] * dn_da, 0.0) + dt_da
    force = p[:, None] * n + traction
    return ContactResponse(
        force,
        traction,
        active=active,
        slipping=slipping,
        df_dr=df_dr,
        df_da=df_da,
        dt_dr=dt_dr,
        dt_da=dt_da,
        dt_dmu=dt_dmu,
        pressure=p,
        normal=n,
    )


def capsule_axis_offset(r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The indenter as a capsule: the sphere below its centre, its shaft (a cylinder of the same
    radius) above. Returns each point's offset from the capsule's axis (nt, 3): ``r`` below the
    centre, ``r`` without its z part above; and its derivative D (nt, 3, 3): I or diag(1, 1, 0).
    The surface is smooth across the equator, so a node that slides up the sphere (frictionless
    or slipping, deeper than R) goes on along the shaft instead of dropping out of contact."""
    up = r[:, 2] > 0.0
    offset = r.copy()
    offset[up, 2] = 0.0
    D = np.broadcast_to(np.eye(3), (r.shape[0], 3, 3)).copy()
    D[up, 2, 2] = 0.0
    return offset, D


def capsule_projection(r: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """The point of the capsule's surface (:func:`capsule_axis_offset`) nearest to ``r`` (nt, 3)
    and its derivative with respect to ``r`` (nt, 3, 3)."""
    offset, D = capsule_axis_offset(r)
    rho = np.linalg.norm(offset, axis=1)
    safe = np.where(rho > 0.0, rho, 1.0)
    n = offset / safe[:, None]
    P = np.eye(3) - n[:, :, None] * n[:, None, :]
    point = r - offset + radius * n
    d = (np.eye(3) - D) + radius * (P / safe[:, None, None]) @ D
    return point, d


def settled_status(
    r: np.ndarray, anchor: np.ndarray, radius: float, status: np.ndarray, tol: float
) -> np.ndarray:
    """The contact statuses the state at ``r`` calls for, given those it was solved with: a free
    node inside the sphere's lower hemisphere by more than ``tol`` (mm) comes into contact; a
    node in contact outside its anchor's tangent plane by more than ``tol`` (pulled) is released.
    Equal to ``status`` when the state is consistent."""
    rho = np.linalg.norm(r, axis=1)
    off = capsule_axis_offset(anchor)[0]
    n = off / np.maximum(np.linalg.norm(off, axis=1), 1e-300)[:, None]
    gap = np.einsum("ij,ij->i", n, r - anchor)
    new = status.copy()
    new[(status == FREE) & (rho < radius - tol) & (r[:, 2] < 0.0)] = CONTACT
    new[(status != FREE) & (gap > tol)] = FREE
    return new


def anchor_crossing_fractions(
    w: np.ndarray, normal: np.ndarray, step: np.ndarray, slipping: np.ndarray
) -> np.ndarray:
    """Each point's largest fraction (<= 1) of its ``step`` (nt, 3) that takes it, if slipping,
    no farther than the plane through its anchor across its slip (``w``: the point's offset from
    its anchor, ``normal``: the indenter's normal there): beyond it the friction would turn
    round, and a Newton step that ignores the stick zone between (mu p / eps wide) jumps from one
    side to the other without end. Stopping at the plane puts the point where it can stick."""
    w_t = w - normal * np.einsum("ij,ij->i", normal, w)[:, None]
    s_t = step - normal * np.einsum("ij,ij->i", normal, step)[:, None]
    towards = np.einsum("ij,ij->i", w_t, s_t)
    back = slipping & (towards < 0.0)
    alpha = np.ones(w.shape[0])
    alpha[back] = np.minimum(1.0, np.einsum("ij,ij->i", w_t[back], w_t[back]) / -towards[back])
    return alpha


def anchor_crossing_step(w: np.ndarray, normal: np.ndarray, step: np.ndarray, slipping: np.ndarray) -> float:
    """The largest fraction (<= 1) of the points' ``step`` that takes no slipping point past
    its anchor's plane: the least of :func:`anchor_crossing_fractions`."""
    return float(anchor_crossing_fractions(w, normal, step, slipping).min(initial=1.0))


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
