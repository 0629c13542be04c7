"""The Coulomb penalty law between the rigid spherical indenter and one contact point: the
indenter's force on it and its exact derivatives, the indenter's surface (a capsule), the statuses
a state calls for and how far a slipping point may step; stateless and vectorised over the points
(:mod:`forward.coulomb_contact` carries the points' statuses and anchors through the increments).

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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "CONTACT",
    "FREE",
    "ContactResponse",
    "anchor_crossing_fractions",
    "anchor_crossing_step",
    "capsule_axis_offset",
    "capsule_projection",
    "contact_response",
    "settled_status",
]

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
        (:meth:`forward.coulomb_contact.FrictionContactState.turning`), never a converged state's.

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
