"""Checks of the DIC field that catch a wrong registration, wrong frames or a wrong file before
a fit (used by :mod:`.data_check`), each a warning with numbers:

* correlated points inside the contact radius at a step: the indenter is opaque, so a point
  whose current position lies within ``INSIDE_FRACTION`` of the contact radius sqrt(2 R d - d^2)
  cannot have been seen (the margin allows for a registration error);
* a field with no indentation signature: at the deepest step used, the surface beside the
  indenter (a < r < 2a) must sink below the far field (the outer 40 % of the field of view) by
  at least ``SIGNATURE_FRACTION`` of the depth (Hertz: by d/2 at the contact's edge) and by
  more than ``SIGNATURE_NOISES`` times the DIC noise;
* a step whose DIC point count drops below ``DROP_FRACTION`` of the step before's;
* registration residuals larger than the DIC noise: the reference positions' spread about the
  top face (:mod:`.specimen_frame`) beyond ``RESIDUAL_NOISES`` times the DIC noise.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from itertools import pairwise

import numpy as np

from .data import ExperimentData
from .processing import RegisteredDIC

INSIDE_FRACTION = 0.9
SIGNATURE_FRACTION = 0.1
SIGNATURE_NOISES = 5.0
DROP_FRACTION = 0.8
RESIDUAL_NOISES = 2.0


def contact_radius(radius: float, depth: float) -> float:
    """The radius of the circle where a sphere pressed ``depth`` into a plane meets it:
    sqrt(2 R d - d^2), and R once the sphere is in past its equator."""
    return float(radius if depth >= radius else np.sqrt(2.0 * radius * depth - depth * depth))


@dataclass
class InsideContact:
    step: int
    points: int
    contact_radius_mm: float
    nearest_mm: float  # the nearest such point's current distance from the indentation axis

    def to_dict(self) -> dict:
        return asdict(self)


def points_inside_contact(exp: ExperimentData, dic: RegisteredDIC) -> list[InsideContact]:
    """Per used step with any: the correlated points whose current position lies inside
    ``INSIDE_FRACTION`` of the contact radius."""
    out = []
    for k in exp.used_steps:
        u = dic.u[k - 1]
        ok = np.isfinite(u).all(axis=1)
        r = np.hypot(*(dic.xyz[:, :2] + np.nan_to_num(u[:, :2])).T)
        a = contact_radius(exp.radius, exp.step_size * k)
        inside = ok & (r < INSIDE_FRACTION * a)
        if inside.any():
            out.append(InsideContact(int(k), int(inside.sum()), a, float(r[inside].min())))
    return out


def indentation_signature(exp: ExperimentData, dic: RegisteredDIC) -> tuple[float, float, int, int] | None:
    """(median uz beside the indenter - median uz of the far field, depth, points beside, points
    far) at the deepest step used, in mm; None when either region has fewer than 10 points."""
    k = int(exp.used_steps[-1])
    d = exp.step_size * k
    a = contact_radius(exp.radius, d)
    u = dic.u[k - 1]
    ok = np.isfinite(u).all(axis=1)
    r = np.hypot(dic.xyz[:, 0], dic.xyz[:, 1])
    near = ok & (r > a) & (r < 2.0 * a)
    far = ok & (r > 0.6 * r[ok].max()) if ok.any() else ok
    if near.sum() < 10 or far.sum() < 10:
        return None
    return float(np.median(u[near, 2]) - np.median(u[far, 2])), d, int(near.sum()), int(far.sum())


def dic_field_warnings(
    exp: ExperimentData, dic: RegisteredDIC, noise: np.ndarray
) -> tuple[list[str], list[InsideContact], float | None]:
    """The warnings of the module docstring, the points inside the contact radius per step and
    the indentation signature (mm; None when it cannot be measured)."""
    warnings = []
    inside = points_inside_contact(exp, dic)
    if inside:
        listed = "; ".join(
            f"step {c.step}: {c.points} within {INSIDE_FRACTION:g} a = {INSIDE_FRACTION * c.contact_radius_mm:.3g} mm "
            f"(nearest at r = {c.nearest_mm:.3g} mm)"
            for c in inside[:6]
        )
        more = f" and {len(inside) - 6} more steps" if len(inside) > 6 else ""
        warnings.append(
            f"correlated DIC points inside the indenter's contact radius, where the opaque indenter hides the "
            f"surface: {listed}{more}; a wrong registration (indentation point), wrong frames or a wrong file?"
        )
    signature = indentation_signature(exp, dic)
    drop = None
    if signature is not None:
        drop, d, n_near, n_far = signature
        k = int(exp.used_steps[-1])
        if not (-drop >= SIGNATURE_FRACTION * d and -drop > SIGNATURE_NOISES * float(noise[2])):
            warnings.append(
                f"step {k} (depth {d:g} mm): the DIC field shows no indentation: uz beside the indenter (a < r < 2a, "
                f"{n_near} points) lies {drop:+.3g} mm from the far field's ({n_far} points), not below it by "
                f"{SIGNATURE_FRACTION:g} x the depth ({SIGNATURE_FRACTION * d:.3g} mm) and {SIGNATURE_NOISES:g} x the "
                f"noise ({SIGNATURE_NOISES * float(noise[2]):.3g} mm); wrong frames, a wrong file or a wrong "
                "registration?"
            )
    counts = np.isfinite(exp.dic_u).all(axis=2).sum(axis=1)
    used = [int(k) for k in exp.used_steps]
    for j, k in pairwise(used):
        if counts[k - 1] < DROP_FRACTION * counts[j - 1]:
            warnings.append(
                f"step {k}: {counts[k - 1]} DIC points, {100 * (1 - counts[k - 1] / counts[j - 1]):.3g} % fewer than "
                f"step {j}'s {counts[j - 1]} (points lost in that frame: a reflection, a smudge, a frame of another "
                "series?)"
            )
    frame = dic.frame
    if frame is not None and frame.surface_rms_mm > RESIDUAL_NOISES * float(np.mean(noise)):
        warnings.append(
            f"the DIC points' spread about the top face ({frame.surface_rms_mm:.3g} mm RMS; face tilted "
            f"{frame.tilt_deg:.3g} deg from the DIC z) is more than {RESIDUAL_NOISES:g} x the DIC noise "
            f"({np.mean(noise):.3g} mm): the face is not flat, or the points are not all on it; the registration's "
            "normal is uncertain"
        )
    return warnings, inside, drop
