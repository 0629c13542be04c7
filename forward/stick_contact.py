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
    attached: np.ndarray = field(init=False)
    anchor: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        n = self.top_xyz0.shape[0]
        self.attached = np.zeros(n, dtype=bool)
        self.anchor = np.zeros((n, 3))

    def copy(self) -> StickContactState:
        other = StickContactState(self.sphere, self.top_xyz0)
        other.attached = self.attached.copy()
        other.anchor = self.anchor.copy()
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
    ) -> None:
        """Attach ``nodes`` (indices into the top set) where their increment path meets the sphere."""
        if nodes.size == 0:
            return
        x0 = self.top_xyz0[nodes]
        r0 = x0 + u_start[nodes] - self.sphere.centre(depth_start)
        r1 = x0 + u_end[nodes] - self.sphere.centre(depth_end)
        self.anchor[nodes] = path_meets_sphere(r0, r1, self.sphere.radius)
        self.attached[nodes] = True

    def normal_reaction(self, reaction_top: np.ndarray) -> np.ndarray:
        """Normal component of the force the sphere exerts on each attached node (positive:
        pushes; negative: pulls). ``reaction_top`` (nt, 3): external force on the top nodes."""
        n = self.anchor / self.sphere.radius
        return np.where(self.attached, np.einsum("ij,ij->i", reaction_top, n), 0.0)
