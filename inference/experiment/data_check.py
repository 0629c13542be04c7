"""The data-quality check of an experiment before any fit: what each processing step of paper
2.7 and 2.8.1 makes of the data, with numbers, and warnings where the data will mislead a fit.

* each hold's eq. 9 fit: f_inf, time constant, residual, and how far from relaxed the force still
  is at the end of the hold (the transient A exp(-b T) left, relative to f_inf);
* DIC coverage per step: points correlated, the radius of the indenter's shadow (the contact
  radius sqrt(2 R d - d^2) of a sphere at depth d) and the field of view in the model frame;
* the sphere fit of the indenter points and its residual (RMS of |x - c| - R);
* the registration: the indentation point in the DIC frame and the fiber direction (given, and
  as the strain field says);
* the FE top nodes of a mesh preset that get data and those obscured;
* the DIC noise per direction of the model frame (x, y along the fibers, z) at the deepest step
  used: the robust spread of each point's displacement about a
  least-squares plane through its neighbours (themselves noisy, hence the leverage correction);
* warnings with numbers: a hold that has not relaxed, a sphere-fit residual larger than the DIC
  noise, a missing or excluded step, a fitted sphere radius that is not the declared one, a
  force that does not grow with depth, a DIC frame with few points, fewer than half the points
  correlated at every step (the only ones the DIC-to-node interpolation uses), and those of
  :mod:`.dic_checks`: points inside the contact radius, a field with no indentation, a step whose
  point count drops, the DIC points' spread about the top face beyond the DIC noise.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from itertools import pairwise
from pathlib import Path

import numpy as np

from ...forward.mesh import preset_mesh
from .data import ExperimentData, ExperimentDataError, load_experiment
from .dic_checks import contact_radius, dic_field_warnings
from .processing import (
    RegisteredDIC,
    _noise_neighbours,
    dic_to_nodes,
    fiber_angle_from_strain,
    fit_sphere,
    relaxation_fit,
    to_model_frame,
)

#: a hold whose remaining transient at its end exceeds this fraction of f_inf, and twice the
#: standard error of f_inf, has not relaxed
UNRELAXED_FRACTION = 0.02
#: a fitted sphere radius this far (relative) from the declared one is warned about
RADIUS_TOLERANCE = 0.02
#: a step with fewer correlated points than this fraction of the best step is warned about
LOW_COVERAGE = 0.5


@dataclass
class HoldCheck:
    step: int
    readings: int
    hold_s: float
    f_inf_mN: float
    f_inf_std_mN: float
    amplitude_mN: float
    tau_s: float
    unrelaxed_pct: float  # A exp(-b T) / f_inf at the end of the hold, percent
    residual_rms_mN: float


@dataclass
class StepCoverage:
    step: int
    depth_mm: float
    points: int
    fraction: float
    shadow_radius_mm: float  # contact radius of the sphere at this depth
    innermost_point_mm: float  # nearest correlated point to the indentation axis
    outermost_point_mm: float


@dataclass
class DataCheck:
    experiment: str
    steps: int
    excluded_steps: list[int]
    missing_steps: list[int]
    holds: list[HoldCheck]
    coverage: list[StepCoverage]
    sphere_centre_mm: list[float]
    sphere_radius_mm: float
    sphere_residual_rms_mm: float
    indentation_point_mm: list[float]
    fiber_angle_deg: float
    fiber_angle_estimated: bool
    fiber_angle_from_strain_deg: float | None
    field_of_view_mm: float
    points: int
    points_every_step: int  # correlated at every step used: the only points the processing uses
    mesh: str
    nodes: int
    nodes_with_data: int
    nodes_obscured: int
    node_xy: list[list[float]] = field(repr=False, default_factory=list)
    node_measured: list[bool] = field(repr=False, default_factory=list)
    dic_noise_mm: list[float] = field(default_factory=list)  # ux, uy (along the fibers), uz
    points_inside_contact: list[dict] = field(default_factory=list)  # per step with any (dic_checks)
    indentation_signature_mm: float | None = None  # uz beside the indenter - far field, deepest step
    registration: dict = field(default_factory=dict)  # the top face, origin and rotation (to_model_frame)
    warnings: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        out = asdict(self)
        out.pop("node_xy")
        out.pop("node_measured")
        return out


def check_holds(exp: ExperimentData) -> list[HoldCheck]:
    """Eq. 9 fitted to every used step's hold, with its residual and how relaxed it ended."""
    out = []
    for k in exp.used_steps:
        g = exp.force[exp.force["step"] == k]
        t, f = g["time_s"].to_numpy(float), g["force_mN"].to_numpy(float)
        fit = relaxation_fit(t, f)
        span = float(np.ptp(t))
        model = fit.amplitude * np.exp(-fit.rate * (t - t.min())) + fit.f_inf
        left = abs(fit.amplitude) * np.exp(-fit.rate * span)
        out.append(
            HoldCheck(
                int(k),
                len(t),
                hold_s=span,
                f_inf_mN=fit.f_inf,
                f_inf_std_mN=fit.f_inf_std,
                amplitude_mN=fit.amplitude,
                tau_s=1.0 / fit.rate,
                unrelaxed_pct=float(100.0 * left / abs(fit.f_inf)),
                residual_rms_mN=float(np.sqrt(np.mean((f - model) ** 2))),
            )
        )
    return out


def dic_noise(xy: np.ndarray, u: np.ndarray, neighbours: int = 12) -> np.ndarray:
    """The DIC noise (3,) in mm of one step's displacements ``u`` (points, 3) at reference
    positions ``xy`` (points, 2): each point against the least-squares plane through its
    ``neighbours`` nearest others, the robust spread (1.4826 MAD) of those differences divided by
    sqrt(1 + 3 / neighbours) (the plane's own noise at the point, to first order)."""
    u, idx, dx = _noise_neighbours(xy, u, neighbours)
    A = np.concatenate([np.ones((*idx.shape, 1)), dx], axis=2)  # (n, k, 3)
    AtA = np.einsum("nki,nkj->nij", A, A) + 1e-12 * np.eye(3)
    Atu = np.einsum("nki,nkd->nid", A, u[idx])
    plane = np.linalg.solve(AtA, Atu)[:, 0, :]  # value at the point itself
    diff = u - plane
    mad = np.median(np.abs(diff - np.median(diff, axis=0)), axis=0)
    return 1.4826 * mad / np.sqrt(1.0 + 3.0 / neighbours)


def _coverage(exp: ExperimentData, dic: RegisteredDIC) -> list[StepCoverage]:
    r = np.hypot(dic.xyz[:, 0], dic.xyz[:, 1])
    counts = np.isfinite(exp.dic_u).all(axis=2).sum(axis=1)
    out = []
    for k in range(1, exp.steps + 1):
        ok = np.isfinite(exp.dic_u[k - 1]).all(axis=1)
        d = exp.step_size * k
        out.append(
            StepCoverage(
                k,
                d,
                int(ok.sum()),
                float(ok.sum() / max(counts.max(), 1)),
                contact_radius(exp.radius, d),
                float(r[ok].min()) if ok.any() else float("nan"),
                float(r[ok].max()) if ok.any() else float("nan"),
            )
        )
    return out


def _top_nodes(mesh: str) -> np.ndarray:
    m = preset_mesh(mesh)
    return m.nodes[m.top][:, :2]


def check_experiment(exp: ExperimentData | str | Path, mesh: str = "default") -> DataCheck:
    """The data check of an experiment (module docstring): holds, DIC coverage, registration.

    Parameters
    ----------
    exp : ExperimentData, str or pathlib.Path
        The experiment, or its folder (loaded with its missing steps left out and reported).
    mesh : str, default "default"
        The mesh preset whose top nodes are matched to the DIC data.

    Returns
    -------
    DataCheck
        The checks of every hold and step, the sphere fit and the steps left out.
    """
    if not isinstance(exp, ExperimentData):
        exp = load_experiment(exp, exclude_missing=True)
    warnings: list[str] = []
    for k in exp.missing_steps:
        readings = int((exp.force["step"] == k).sum())
        points = int(np.isfinite(exp.dic_u[k - 1]).all(axis=1).sum())
        warnings.append(
            f"step {k} is missing: {readings} force readings, {points} DIC points; a fit refuses the experiment "
            "until the step is restored or listed in experiment.json's excluded_steps"
        )
    for k in sorted(set(exp.excluded_steps) - set(exp.missing_steps)):
        has_force = bool((exp.force["step"] == k).any())
        has_dic = bool(np.isfinite(exp.dic_u[k - 1]).all(axis=1).any())
        warnings.append(
            f"step {k} is excluded from the fit ({'has' if has_force else 'no'} force readings, "
            f"{'has' if has_dic else 'no'} DIC points)"
        )
    holds = check_holds(exp)
    for h in holds:
        if h.unrelaxed_pct > 100 * max(UNRELAXED_FRACTION, 2 * h.f_inf_std_mN / abs(h.f_inf_mN)):
            warnings.append(
                f"step {h.step}: the hold has not relaxed: the force still carries {h.unrelaxed_pct:.2g} % of f_inf "
                f"in its transient after {h.hold_s:.3g} s (tau = {h.tau_s:.3g} s); eq. 9 extrapolates f_inf"
            )
    for a, b in pairwise(holds):
        if b.f_inf_mN <= a.f_inf_mN:
            warnings.append(
                f"step {b.step}: f_inf = {b.f_inf_mN:.4g} mN is not above step {a.step}'s {a.f_inf_mN:.4g} mN "
                "(a slipped step?)"
            )
    centre, radius = fit_sphere(exp.indenter_xyz)
    sphere_rms = float(np.sqrt(np.mean((np.linalg.norm(exp.indenter_xyz - centre, axis=1) - radius) ** 2)))
    if abs(radius / exp.radius - 1) > RADIUS_TOLERANCE:
        warnings.append(
            f"the indenter points fit a sphere of radius {radius:.4g} mm, not the declared {exp.radius:g} mm "
            f"({100 * (radius / exp.radius - 1):+.2g} %)"
        )
    dic = to_model_frame(exp)
    strain_angle = None
    try:
        deepest = exp.used_steps[-1] - 1
        L = dic.frame.leveling if dic.frame is not None else np.eye(3)
        strain_angle = fiber_angle_from_strain(
            ((exp.dic_xyz - dic.origin) @ L.T)[:, :2],
            exp.dic_u[deepest] @ L.T,
            1.5 * exp.radius,
            4.0 * exp.radius,
        )
    except ExperimentDataError as exc:
        warnings.append(f"the fiber direction cannot be read from the strain field: {exc}")
    if strain_angle is not None and not dic.fiber_angle_estimated:
        diff = (strain_angle - dic.fiber_angle_deg + 90.0) % 180.0 - 90.0
        if abs(diff) > 10.0:
            warnings.append(
                f"the declared fiber direction {dic.fiber_angle_deg:.3g} deg differs from the strain field's "
                f"{strain_angle:.3g} deg by {diff:+.3g} deg"
            )
    deepest = exp.used_steps[-1] - 1
    noise = dic_noise(dic.xyz[:, :2], dic.u[deepest])
    if sphere_rms > float(np.mean(noise)):
        warnings.append(
            f"the sphere fit's residual ({sphere_rms:.3g} mm RMS) is larger than the DIC noise "
            f"({np.mean(noise):.3g} mm, mean of ux, uy, uz): the indenter points are not all on the sphere, or the "
            "registration's origin is uncertain"
        )
    coverage = _coverage(exp, dic)
    for c in coverage:
        if c.step not in exp.excluded_steps and c.fraction < LOW_COVERAGE:
            warnings.append(
                f"step {c.step}: only {c.points} DIC points ({100 * c.fraction:.3g} % of the best step's)"
            )
    field_warnings, inside, signature = dic_field_warnings(exp, dic, noise)
    warnings.extend(field_warnings)
    every = int(np.isfinite(exp.dic_u[exp.used_steps - 1]).all(axis=(0, 2)).sum())
    if every < LOW_COVERAGE * len(exp.dic_xyz):
        warnings.append(
            f"only {every} of {len(exp.dic_xyz)} DIC points ({100 * every / len(exp.dic_xyz):.3g} %) are correlated at "
            "every step used, and the DIC-to-node interpolation uses only those"
        )
    node_xy = _top_nodes(mesh)
    _, measured = dic_to_nodes(dic, node_xy, used_steps=exp.used_steps)
    r = np.hypot(dic.xyz[:, 0], dic.xyz[:, 1])
    return DataCheck(
        experiment=str(exp.root),
        steps=exp.steps,
        excluded_steps=list(exp.excluded_steps),
        missing_steps=list(exp.missing_steps),
        holds=holds,
        coverage=coverage,
        sphere_centre_mm=centre.tolist(),
        sphere_radius_mm=radius,
        sphere_residual_rms_mm=sphere_rms,
        indentation_point_mm=dic.origin.tolist(),
        fiber_angle_deg=dic.fiber_angle_deg,
        fiber_angle_estimated=dic.fiber_angle_estimated,
        fiber_angle_from_strain_deg=strain_angle,
        field_of_view_mm=float(r.max()),
        points=len(exp.dic_xyz),
        points_every_step=every,
        mesh=mesh,
        nodes=len(node_xy),
        nodes_with_data=int(measured.sum()),
        nodes_obscured=int((~measured).sum()),
        node_xy=node_xy.tolist(),
        node_measured=measured.tolist(),
        dic_noise_mm=noise.tolist(),
        points_inside_contact=[c.to_dict() for c in inside],
        indentation_signature_mm=signature,
        registration=dic.to_dict(),
        warnings=warnings,
    )
