"""Near-perfect stick contact between a rigid sphere and the block's top-surface nodes.

The paper models the indenter with FEBio's sliding-elastic contact and a friction coefficient
of 1e8 (2.4.1), i.e. no slip once in contact. Here that limit is imposed exactly, node by node:

* a free top node whose path in an increment meets the sphere is **attached** at the point where
  its path (relative to the moving sphere) first crosses the sphere surface; from then on it
  moves rigidly with the indenter (all three displacement components prescribed);
* an attached node whose reaction pulls on the sphere (negative normal reaction) is **released**;
* the indenter force is the sum of the attached nodes' vertical reactions.

Only the lower hemisphere is a contact surface, as in FEBio's indenter mesh (a quarter of the
lower hemisphere as tri3 shells); deeper than R the block wraps around the shaft freely.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class RigidSphere:
    """A sphere of ``radius`` on the z axis whose lowest point is at ``top_z - depth``."""

    radius: float
    top_z: float

    def centre(self, depth: float) -> np.ndarray:
        return np.array([0.0, 0.0, self.top_z + self.radius - depth])


def path_meets_sphere(r0: np.ndarray, r1: np.ndarray, radius: float) -> np.ndarray:
    """Point where the straight path r0 -> r1 (positions relative to the sphere's centre,
    (n, 3)) first meets the sphere |r| = radius, projected exactly onto it. A path that starts
    inside meets it at its start."""
    d = r1 - r0
    a = np.einsum("ij,ij->i", d, d)
    b = np.einsum("ij,ij->i", r0, d)
    c = np.einsum("ij,ij->i", r0, r0) - radius**2
    disc = np.maximum(b * b - a * c, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        alpha = np.where(a > 0.0, (-b - np.sqrt(disc)) / a, 0.0)
    alpha = np.clip(np.where(c <= 0.0, 0.0, alpha), 0.0, 1.0)
    r = r0 + alpha[:, None] * d
    norm = np.linalg.norm(r, axis=1)
    fallback = np.array([0.0, 0.0, -radius])
    return np.where(norm[:, None] > 0.0, r * (radius / np.where(norm > 0, norm, 1.0))[:, None], fallback)


@dataclass
class StickContactState:
    """Which top nodes are attached and where on the sphere (``anchor``: position relative to
    the sphere's centre, fixed while attached)."""

    sphere: RigidSphere
    top_xyz0: np.ndarray  # (nt, 3) reference positions of the top nodes
    n_params: int = 2
    attached: np.ndarray = field(init=False)
    anchor: np.ndarray = field(init=False)
    danchor: np.ndarray = field(init=False)  # (nt, 3, p): d anchor / d theta

    def __post_init__(self) -> None:
        n = self.top_xyz0.shape[0]
        self.attached = np.zeros(n, dtype=bool)
        self.anchor = np.zeros((n, 3))
        self.danchor = np.zeros((n, 3, self.n_params))

    def copy(self) -> StickContactState:
        other = StickContactState(self.sphere, self.top_xyz0, self.n_params)
        other.attached = self.attached.copy()
        other.anchor = self.anchor.copy()
        other.danchor = self.danchor.copy()
        return other

    def prescribed_displacement(self, depth: float) -> np.ndarray:
        """Displacements (nt, 3) that put each attached node at its anchor on the sphere."""
        return self.sphere.centre(depth) + self.anchor - self.top_xyz0

    def penetrating(self, u_top: np.ndarray, depth: float, tol: float) -> np.ndarray:
        """Free nodes inside the lower hemisphere at ``depth`` (by more than ``tol``)."""
        rel = self.top_xyz0 + u_top - self.sphere.centre(depth)
        inside = np.linalg.norm(rel, axis=1) < self.sphere.radius - tol
        return ~self.attached & inside & (rel[:, 2] < 0.0)

    def attach(
        self,
        nodes: np.ndarray,
        u_start: np.ndarray,
        depth_start: float,
        u_end: np.ndarray,
        depth_end: float,
        du_start: np.ndarray | None = None,
        du_end: np.ndarray | None = None,
    ) -> None:
        """Attach ``nodes`` (indices into the top set) where their increment path meets the
        sphere. With ``du_start``/``du_end`` ((nt, 3, p): derivatives of the path's end points
        with respect to the parameters) the anchors' derivatives are recorded too."""
        if nodes.size == 0:
            return
        x0 = self.top_xyz0[nodes]
        r0 = x0 + u_start[nodes] - self.sphere.centre(depth_start)
        r1 = x0 + u_end[nodes] - self.sphere.centre(depth_end)
        anchor = path_meets_sphere(r0, r1, self.sphere.radius)
        self.anchor[nodes] = anchor
        self.attached[nodes] = True
        if du_start is not None and du_end is not None:
            self.danchor[nodes] = anchor_derivative(r0, r1, anchor, du_start[nodes], du_end[nodes])

    def normal_reaction(self, reaction_top: np.ndarray) -> np.ndarray:
        """Normal component of the force the sphere exerts on each attached node (positive:
        pushes; negative: pulls). ``reaction_top`` (nt, 3): external force on the top nodes."""
        n = self.anchor / self.sphere.radius
        return np.where(self.attached, np.einsum("ij,ij->i", reaction_top, n), 0.0)


def anchor_derivative(
    r0: np.ndarray, r1: np.ndarray, anchor: np.ndarray, dr0: np.ndarray, dr1: np.ndarray
) -> np.ndarray:
    """Derivative (n, 3, p) of :func:`path_meets_sphere` with respect to parameters that move
    the path's end points by ``dr0``, ``dr1`` (n, 3, p).

    With p(alpha) = r0 + alpha (r1 - r0) and |p| = R at the crossing, differentiating
    |p|^2 = R^2 gives d alpha = -p.(dr0 + alpha d(r1 - r0)) / p.(r1 - r0); the anchor's
    derivative is dp projected on the sphere's tangent plane. A path that starts inside (alpha
    clipped to 0) gives the projected derivative of r0."""
    delta = r1 - r0
    inside = np.einsum("ij,ij->i", r0, r0) <= np.einsum("ij,ij->i", anchor, anchor) * (1 + 1e-12)
    alpha = np.zeros(r0.shape[0])
    moving = ~inside & (np.einsum("ij,ij->i", delta, delta) > 0)
    # alpha from the anchor's position along the path (least squares along delta)
    alpha[moving] = np.einsum("ij,ij->i", anchor[moving] - r0[moving], delta[moving]) / np.einsum(
        "ij,ij->i", delta[moving], delta[moving]
    )
    ddelta = dr1 - dr0
    dp = dr0 + alpha[:, None, None] * ddelta
    p_dot_delta = np.einsum("ij,ij->i", anchor, delta)
    safe = moving & (np.abs(p_dot_delta) > 0)
    dalpha = np.zeros((r0.shape[0], dr0.shape[2]))
    dalpha[safe] = -np.einsum("ij,ijk->ik", anchor[safe], dp[safe]) / p_dot_delta[safe, None]
    dp = dp + dalpha[:, None, :] * delta[:, :, None]
    radius = np.linalg.norm(anchor, axis=1)
    scale = np.where(inside, radius / np.maximum(np.linalg.norm(r0, axis=1), 1e-300), 1.0)
    n = anchor / radius[:, None]
    dp = dp - n[:, :, None] * np.einsum("ij,ijk->ik", n, dp)[:, None, :]
    return scale[:, None, None] * dp
