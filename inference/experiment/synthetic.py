"""Synthetic experiments in the data format of :mod:`inference.experiment.data`, from any Predictor.

Made on a finer mesh than the fit uses (no inverse crime): the model's top-surface field is
interpolated at random DIC-like points over a field of view, the indenter's shadow removed, the
full field unfolded from the quarter model by symmetry, displacement noise added (a fraction of
max |u| of each direction), the whole expressed in a DIC frame that is shifted and rotated from
the model frame (fibers at ``fiber_angle_deg`` from the DIC x axis); each step's force becomes
a relaxation curve (eq. 9) with noise; points on the indenter's upper cap are written for the
sphere fit.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from ...forward.convergence.mesh_study import top_field_interpolator
from .folder import write_experiment_folder
from .processing import rotation_to_fibers


@dataclass(frozen=True)
class Recording:
    """How a DIC system and a load cell record a model run (:func:`write_experiment_from_model`).

    Parameters
    ----------
    u_noise : float, default 0.02
        Displacement noise as a fraction of max |u| per direction.
    u_noise_mm : float, optional
        Displacement noise in mm instead of ``u_noise``.
    f_noise : float, default 0.02
        Relative force noise.
    points : int, default 6000
        DIC points.
    fov : float, default 25.0
        The DIC field of view's radius, mm.
    fiber_angle_deg : float or None, default 60.0
        The fiber direction in the DIC frame, degrees from x.
    write_fiber_angle : bool, default True
        State the fiber angle in experiment.json (else it is to be estimated).
    frame_offset : tuple of float, default (3.0, -2.0, 12.0)
        The shift of the DIC frame's origin (added to the rotated model coordinates), mm.
    hold_s : float, default 30.0
        Length of each hold, s.
    misregistration_mm : float, default 0.0
        Moves the indenter's cap by that much in a random in-plane direction, so that the
        registration (the sphere fit) puts the indentation point that far from the truth.
    """

    u_noise: float = 0.02
    u_noise_mm: float | None = None
    f_noise: float = 0.02
    points: int = 6000
    fov: float = 25.0
    fiber_angle_deg: float | None = 60.0
    write_fiber_angle: bool = True
    frame_offset: tuple[float, float, float] = (3.0, -2.0, 12.0)
    hold_s: float = 30.0
    misregistration_mm: float = 0.0


#: How a lab records a model run by default (the FEBio run's and the composite's experiments): 0.02 mm
#: DIC noise, 2 % force noise, 0.1 mm misregistration, 6,000 points over a 25 mm field of view,
#: fibers at 60 deg in the DIC frame.
LAB_RECORDING = Recording(u_noise_mm=0.02, f_noise=0.02, misregistration_mm=0.1, fov=25.0, points=6000)


def write_synthetic_experiment(
    predictor,
    theta,
    out_dir: str | Path,
    radius: float,
    step_size: float,
    *,
    recording: Recording = Recording(),
    seed: int = 0,
    source: dict | None = None,
    **options: object,
) -> Path:
    """Simulate ``theta`` with ``predictor`` and write an experiment folder.

    A step whose force the predictor gives as NaN (a recorded FEBio step off equilibrium) gets no
    force readings and is listed in experiment.json's ``excluded_steps``.

    Parameters
    ----------
    predictor : Predictor
        The model.
    theta : array_like
        (c1, c5), kPa: the truth.
    out_dir : str or pathlib.Path
        The experiment folder.
    radius : float
        The indenter's radius, mm.
    step_size : float
        Indentation per step, mm.
    recording : Recording, optional
        How it is recorded (noise, field of view, frame, registration error); default
        ``Recording()``.
    seed : int, default 0
        The noise seed.
    source : dict, optional
        Recorded under ``synthetic`` (e.g. the FEBio run it was made from).
    **options
        Fields of :class:`Recording` that replace ``recording``'s (e.g. ``f_noise=0.01``).

    Returns
    -------
    pathlib.Path
        The experiment folder.

    Examples
    --------
    >>> import indentation_studio as ins
    >>> fe = ins.FESolverPredictor(ins.ModelSpec())
    >>> ins.write_synthetic_experiment(fe, (10.0, 350.0), "exp", 4.77, 0.5)  # doctest: +SKIP
    """
    pred = predictor.predict(np.asarray(theta, float)[None, :])
    return write_experiment_from_model(
        pred.force[0],
        pred.displacement[0],
        pred.top_xyz,
        out_dir,
        radius=radius,
        step_size=step_size,
        truth=[float(v) for v in np.ravel(theta)],
        model=_model_of(predictor, source),
        recording=replace(recording, **options),
        seed=seed,
        source=source,
    )


def write_experiment_from_model(
    force: np.ndarray,
    field: np.ndarray,
    top: np.ndarray,
    out_dir: str | Path,
    *,
    radius: float,
    step_size: float,
    truth: list[float] | None = None,
    model: dict | None = None,
    recording: Recording = Recording(),
    seed: int = 0,
    source: dict | None = None,
) -> Path:
    """Write the experiment folder of one model run, as a DIC system and a load cell would record it.

    See the module docstring for the recording.

    Parameters
    ----------
    force : numpy.ndarray
        (steps,) force of the whole specimen, mN.
    field : numpy.ndarray
        (steps, n_top, 3) the quarter model's top-node displacements, mm.
    top : numpy.ndarray
        (n_top, 3) the top nodes, mm.
    out_dir : str or pathlib.Path
        The experiment folder.
    radius : float
        The indenter's radius, mm.
    step_size : float
        Indentation per step, mm.
    truth : list of float, optional
        The (c1, c5) that made it; None where no homogeneous parameters did (the composite
        phantom).
    model : dict, optional
        The spec of the model.
    recording : Recording, optional
        How it is recorded (noise, DIC points, field of view, frame, holds, registration error);
        default ``Recording()``.
    seed : int, default 0
        The noise seed.
    source : dict, optional
        Recorded under ``synthetic``.

    Returns
    -------
    pathlib.Path
        The experiment folder.
    """
    rec = recording
    u_noise, u_noise_mm, f_noise = rec.u_noise, rec.u_noise_mm, rec.f_noise
    points, fov, fiber_angle_deg = rec.points, rec.fov, rec.fiber_angle_deg
    rng = np.random.default_rng(seed)
    out = Path(out_dir)
    force, field, top = np.asarray(force, float), np.asarray(field, float), np.asarray(top, float)
    steps = len(force)
    # DIC points over the field of view in the model frame, the indenter's shadow removed
    r = fov * np.sqrt(rng.random(points))
    phi = 2 * np.pi * rng.random(points)
    xy = np.column_stack([r * np.cos(phi), r * np.sin(phi)])
    xy = xy[r > radius]
    interp = top_field_interpolator(top, np.moveaxis(field, 0, 1))
    half = top[:, :2].max(axis=0)
    u = interp(np.minimum(np.abs(xy), half))  # (points, steps, 3)
    u = np.moveaxis(u, 0, 1)
    u[..., 0] *= np.sign(xy[:, 0])
    u[..., 1] *= np.sign(xy[:, 1])
    scale = (
        np.nanmax(np.abs(u), axis=(0, 1)) * u_noise if u_noise_mm is None else np.full(3, float(u_noise_mm))
    )
    u = u + scale * rng.standard_normal(u.shape)
    xyz_model = np.column_stack([xy, np.zeros(len(xy))])
    # the DIC frame: fibers (model +y) at fiber_angle_deg from its x axis, origin shifted
    Q = rotation_to_fibers(fiber_angle_deg if fiber_angle_deg is not None else 90.0).T
    offset = np.asarray(rec.frame_offset, float)
    xyz_dic = xyz_model @ Q.T + offset
    u_dic = u @ Q.T
    # the indenter's upper cap in the reference state (sphere touching the surface at the origin)
    k = 400
    a, b = 2 * np.pi * rng.random(k), np.arccos(rng.uniform(0.2, 1.0, k))
    cap = radius * np.column_stack([np.sin(b) * np.cos(a), np.sin(b) * np.sin(a), 1.0 + np.cos(b)])
    cap = cap + 0.002 * rng.standard_normal(cap.shape)
    slip = rng.uniform(0.0, 2 * np.pi) if rec.misregistration_mm else 0.0  # no draw: same noise as before
    cap_shift = rec.misregistration_mm * np.array([np.cos(slip), np.sin(slip), 0.0])
    cap = cap + cap_shift
    # relaxation during each hold (eq. 9): f(t) = f_inf (1 + 0.3 exp(-t / 8 s)), readings every second
    t = np.arange(0.0, rec.hold_s + 1e-9, 1.0)
    rows = []
    unknown = [s + 1 for s in range(steps) if not np.isfinite(force[s])]
    for s in range(steps):
        if s + 1 in unknown:
            continue
        f = force[s] * (1.0 + 0.3 * np.exp(-t / 8.0))
        f = f + f_noise * force[s] * rng.standard_normal(t.size)
        rows.append(pd.DataFrame({"step": s + 1, "time_s": t, "force_mN": f}))
    meta = {
        "radius_mm": radius,
        "step_size_mm": step_size,
        "steps": steps,
        "fiber_angle_deg": fiber_angle_deg if rec.write_fiber_angle else None,
        "description": "synthetic",
        **({"excluded_steps": unknown} if unknown else {}),
        "synthetic": {
            "theta": truth,
            "u_noise": u_noise if u_noise_mm is None else None,
            "u_noise_mm": u_noise_mm,
            "misregistration_mm": cap_shift.tolist(),
            "f_noise": f_noise,
            "points": len(xy),
            "fov_mm": fov,
            "true_fiber_angle_deg": fiber_angle_deg,
            "frame_offset": offset.tolist(),
            "seed": seed,
            "model": model,
            **({"source": source} if source else {}),
        },
    }
    # the one validated, atomic writer of the format (files already beside it are kept)
    return write_experiment_folder(
        out, meta, pd.concat(rows), xyz_dic, u_dic, cap @ Q.T + offset, overwrite=True, keep_other_files=True
    )


def _model_of(predictor, source: dict | None) -> dict | None:
    """The spec of the model that made the data; its contact the one the source names when it has
    one the studio's spec cannot say (FEBio's sliding-elastic contact of a recorded run)."""
    spec = getattr(predictor, "spec", None)
    model = spec.to_dict() if spec is not None else None
    if model is not None and source and "contact" in source:
        model["contact"] = source["contact"]
    return model
