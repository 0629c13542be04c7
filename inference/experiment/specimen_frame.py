"""DIC positions in the cameras' coordinates brought to the specimen's frame.

A stereo-DIC program reconstructs points in the coordinates of its calibration: z away from
the camera, the specimen tilted (DuoDIC's example strip, 16 degrees). The specimen's frame of
the model has its top face in the plane z = 0 and z along the face's outward normal. The plane
fitted to the reference positions of the DIC points (least squares, SVD) is the top face; its
normal, oriented towards the indenter's sphere centre, is the model's +z; the *leveling*
rotation is the smallest rotation that takes that normal onto +z (a rotation about an axis in
the face), so that a specimen already in the studio's frame (face in z = const) is left as it is.
The indentation point is the sphere's point nearest the face, c - R n; it must lie on the face:
farther from the plane than ``max(MAX_OFF_SURFACE_MM, OFF_SURFACE_NOISES x noise)`` (noise: the
robust spread of the reference positions about the plane) is an error naming the distance: the
sphere or the DIC points are in another frame, or the wrong file.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .data import ExperimentDataError

MAX_OFF_SURFACE_MM = 0.5
OFF_SURFACE_NOISES = 5.0


@dataclass(frozen=True)
class SpecimenFrame:
    """The top face found in the DIC data: ``normal`` (unit, DIC frame, towards the indenter),
    ``point`` on it (the centroid of the points), ``leveling`` (3, 3) DIC frame -> leveled frame
    (normal onto +z), ``tilt_deg`` the angle between the normal and the DIC z, ``surface_rms_mm``
    the RMS and ``surface_noise_mm`` the robust spread (1.4826 MAD) of the points' distances from
    the plane, ``indentation_point_mm`` (DIC frame) and its signed distance from the plane."""

    normal: np.ndarray
    point: np.ndarray
    leveling: np.ndarray
    tilt_deg: float
    surface_rms_mm: float
    surface_noise_mm: float
    indentation_point_mm: np.ndarray
    off_surface_mm: float

    def to_dict(self) -> dict:
        return {
            "surface_normal": self.normal.tolist(),
            "surface_point_mm": self.point.tolist(),
            "leveling_rotation": self.leveling.tolist(),
            "tilt_deg": self.tilt_deg,
            "surface_rms_mm": self.surface_rms_mm,
            "surface_noise_mm": self.surface_noise_mm,
            "indentation_point_off_surface_mm": self.off_surface_mm,
        }


def surface_plane(xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The least-squares plane through ``xyz`` (n, 3): a point on it (the centroid) and its unit
    normal (sign not fixed)."""
    xyz = np.asarray(xyz, float)
    xyz = xyz[np.isfinite(xyz).all(axis=1)]
    if len(xyz) < 3:
        raise ExperimentDataError("fewer than 3 DIC points: no plane for the specimen's top face")
    centroid = xyz.mean(axis=0)
    _, _, vt = np.linalg.svd(xyz - centroid, full_matrices=False)
    return centroid, vt[2] / np.linalg.norm(vt[2])


def leveling_rotation(normal: np.ndarray) -> np.ndarray:
    """The smallest rotation (3, 3) taking the unit ``normal`` onto +z (Rodrigues; about an axis
    in the plane z = 0)."""
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(n, z)
    s, c = np.linalg.norm(axis), float(n @ z)
    if s < 1e-15:
        if c > 0:
            return np.eye(3)
        return np.diag([1.0, -1.0, -1.0])  # upside down: half a turn about x
    k = axis / s
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    angle = np.arctan2(s, c)
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * (K @ K)


def specimen_frame(xyz: np.ndarray, centre: np.ndarray, radius: float) -> SpecimenFrame:
    """The top face of the DIC reference positions ``xyz`` and the indentation point of the
    sphere (``centre``, ``radius``) on it (module docstring); an error when that point is off
    the face."""
    point, normal = surface_plane(xyz)
    if (np.asarray(centre) - point) @ normal < 0:
        normal = -normal
    R = leveling_rotation(normal)
    dist = (np.asarray(xyz, float) - point) @ normal
    dist = dist[np.isfinite(dist)]
    rms = float(np.sqrt(np.mean(dist**2)))
    noise = float(1.4826 * np.median(np.abs(dist - np.median(dist))))
    ip = np.asarray(centre, float) - radius * normal
    off = float((ip - point) @ normal)
    limit = max(MAX_OFF_SURFACE_MM, OFF_SURFACE_NOISES * noise)
    tilt = float(np.degrees(np.arccos(np.clip(abs(normal[2]), -1.0, 1.0))))
    if abs(off) > limit:
        raise ExperimentDataError(
            f"the indentation point (the sphere's point nearest the specimen's top face) lies {off:+.3g} mm from the "
            f"face the DIC points define (limit {limit:.3g} mm: {MAX_OFF_SURFACE_MM:g} mm or {OFF_SURFACE_NOISES:g} "
            f"times the points' {noise:.2g} mm spread about it; face tilted {tilt:.3g} deg from the DIC z): the "
            "indenter points and the DIC points are not in one frame, or a file is the wrong one"
        )
    return SpecimenFrame(
        normal,
        point,
        leveling=R,
        tilt_deg=tilt,
        surface_rms_mm=rms,
        surface_noise_mm=noise,
        indentation_point_mm=ip,
        off_surface_mm=off,
    )
