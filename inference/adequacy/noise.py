"""The noise model the adequacy test whitens a fit's residuals by:

* force, per step: the standard error of f_inf from that hold's eq. 9 fit (its residuals about
  f(t) = A exp(-b t) + f_inf); declared (a relative noise of each reading), that standard error
  scaled by the declared noise over the hold's residual; or, when a hold gives none, the noise
  the experiment records (a synthetic one's ``f_noise``);
* DIC, per direction of the model frame: measured from the data (each point against a local
  quadratic through its neighbours, the fit's own leverage taken out exactly, robust spread
  over the points) or declared, in mm; at each FE node it is carried through the very planes
  that interpolate the DIC points there (:func:`inference.experiment.processing.node_interpolation`),
  so nodes sharing points are correlated as they are;
* the registration: the indentation point's in-plane standard error from the sphere fit's
  residual, moving every node's value by the field's gradient there (a rank-two term, solved
  by Woodbury's identity); and the registration uncertainty the fit declares
  (``registration_mm``, the same 0.1 mm by default that the processing's part of the bounds
  moves the point by), profiled: the data are processed again about indentation points on rings
  within it (:func:`registration_alternatives`: the folding, the nearest points and the planes
  run again, which no gradient at the nodes holds next to the symmetry planes), and the
  statistic is the least over these readings, with two degrees of freedom given to the choice.
  The sphere fit's own error is small; what a lab's registration gets wrong is where the tracked
  cap lies against the DIC surface, which no residual shows.
* the model's own stated uncertainty: for a multi-fidelity surrogate, its discrepancy's predictive
  covariance at the fit (the same that the bounds' discrepancy part carries), moved through eq. 5
  into the residuals (a low-rank term beside the registration's). The test then asks whether the
  model explains the data within the noise and within what the model says it does not know."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..experiment.data import ExperimentData
from ..experiment.errors import ExperimentDataError
from ..experiment.processing import (
    RegisteredDIC,
    _noise_neighbours,
    fit_sphere,
)
from ..experiment.relaxation import relaxation_fit

__all__ = ["NoiseModel", "dic_noise_mm", "force_noise_per_step", "noise_model"]


@dataclass
class NoiseModel:
    """The measurement noise a fit's residuals are whitened by, and where each part came from.

    Attributes
    ----------
    force_sd_mN : numpy.ndarray
        (steps used,) standard error of each step's f_inf, mN.
    force_source : str
        Where it came from.
    dic_sd_mm : numpy.ndarray
        (3,) ux, uy, uz noise in the model frame, mm.
    dic_source : str
        Where it came from.
    origin_cov_mm2 : numpy.ndarray
        (2, 2) the indentation point's in-plane covariance (model frame), mm^2.
    registration_source : str
        Where it came from.
    """

    force_sd_mN: np.ndarray  # (steps used,) standard error of each step's f_inf
    force_source: str
    dic_sd_mm: np.ndarray  # (3,) ux, uy, uz in the model frame
    dic_source: str
    origin_cov_mm2: np.ndarray  # (2, 2) the indentation point's in-plane covariance (model frame)
    registration_source: str

    def to_dict(self) -> dict:
        """The noise as JSON-ready lists, the registration as its standard deviations (mm).

        Returns
        -------
        dict
            Each part and where it came from.
        """
        return {
            "force_sd_mN": self.force_sd_mN.tolist(),
            "force_source": self.force_source,
            "dic_sd_mm": self.dic_sd_mm.tolist(),
            "dic_source": self.dic_source,
            "registration_sd_mm": np.sqrt(np.diag(self.origin_cov_mm2)).tolist(),
            "registration_source": self.registration_source,
        }


# ------------------------------------------------------------------------------------ noise
def _recorded(exp: ExperimentData) -> dict:
    """The noise experiment.json records (a synthetic experiment's 'synthetic' block), or {}."""
    return exp.synthetic


def force_noise_per_step(
    exp: ExperimentData, steps: np.ndarray, declared: float | None = None
) -> tuple[np.ndarray, np.ndarray, str]:
    """The standard error (mN) of f_inf at each of ``steps`` (1..N) and f_inf itself, with where
    the noise came from. By default from each hold's eq. 9 fit (its residuals); ``declared``
    (relative noise of one reading) scales that standard error by declared / the hold's residual
    RMS in units of f_inf (the fit's covariance is proportional to the residual variance); a hold
    that gives no standard error takes the recorded noise (a synthetic experiment's f_noise) over
    sqrt(readings)."""
    recorded = _recorded(exp).get("f_noise")
    sd, f_inf, fallback = [], [], []
    for k in steps:
        g = exp.force[exp.force["step"] == k]
        t, f = g["time_s"].to_numpy(float), g["force_mN"].to_numpy(float)
        try:
            fit = relaxation_fit(t, f)
        except ExperimentDataError:
            fit = None
        if fit is not None:
            model = fit.amplitude * np.exp(-fit.rate * (t - t.min())) + fit.f_inf
            rms = float(np.sqrt(np.mean((f - model) ** 2)))
            f_inf.append(fit.f_inf)
            good = np.isfinite(fit.f_inf_std) and fit.f_inf_std > 0 and len(t) > 3
            if good and declared is None:
                sd.append(fit.f_inf_std)
                continue
            if good and rms > 0:
                sd.append(fit.f_inf_std * declared * abs(fit.f_inf) / rms)
                continue
        else:
            f_inf.append(float(np.median(f)))
        level = declared if declared is not None else recorded
        if level is None:
            raise ExperimentDataError(
                f"step {k}: its hold gives no standard error of f_inf (eq. 9 with {len(t)} readings) and no "
                "force noise is declared or recorded; declare one (force_noise)"
            )
        sd.append(float(level) * abs(f_inf[-1]) / np.sqrt(max(len(t), 1)))
        fallback.append(int(k))
    if declared is not None:
        source = f"declared: {100 * declared:.3g} % of f_inf per reading, through each hold's eq. 9 fit"
    else:
        source = "measured: the standard error of f_inf from each hold's eq. 9 residuals"
    if fallback:
        source += (
            f"; steps {fallback}: the recorded {100 * float(recorded or declared):.3g} % over sqrt(readings)"
        )
    return np.array(sd), np.array(f_inf), source


def dic_noise_mm(xy: np.ndarray, u: np.ndarray, neighbours: int = 24) -> np.ndarray:
    """The DIC noise (3,) in mm of one step's displacements ``u`` (points, 3) at ``xy`` (points,
    2): each point against the least-squares quadratic through its ``neighbours`` nearest
    others (a quadratic, so that the field's curvature next to the indenter does not read as
    noise), the difference divided by sqrt(1 + c . c) with c the quadratic's weights of its
    neighbours at the point (the variance of the difference is sigma^2 (1 + c . c), exactly),
    and the robust spread (1.4826 MAD) of those over the points."""
    u, idx, d = _noise_neighbours(xy, u, neighbours)  # d: (n, k, 2)
    scale = np.sqrt(np.mean(np.sum(d**2, axis=2), axis=1))[:, None, None]
    d = d / scale
    A = np.concatenate(
        [np.ones((*idx.shape, 1)), d, d[..., :1] ** 2, d[..., :1] * d[..., 1:], d[..., 1:] ** 2], axis=2
    )  # (n, k, 6)
    AtA = np.einsum("nki,nkj->nij", A, A) + 1e-12 * np.eye(6)
    c = np.linalg.solve(AtA, np.transpose(A, (0, 2, 1)))[:, 0, :]  # (n, k): weights at the point
    diff = (u - np.einsum("nk,nkd->nd", c, u[idx])) / np.sqrt(1.0 + np.sum(c**2, axis=1))[:, None]
    mad = np.median(np.abs(diff - np.median(diff, axis=0)), axis=0)
    return 1.4826 * mad


def _origin_covariance(exp: ExperimentData, dic: RegisteredDIC) -> np.ndarray:
    """The in-plane covariance (2, 2), model frame, of the indentation point from the sphere fit:
    its residual's variance times (J^T J)^-1, J the Jacobian of |x - c| - R in (c, R)."""
    x = np.asarray(exp.indenter_xyz, float)
    centre, radius = fit_sphere(x)
    v = x - centre
    n = v / np.linalg.norm(v, axis=1, keepdims=True)
    J = np.column_stack([-n, -np.ones(len(x))])
    res = np.linalg.norm(v, axis=1) - radius
    dof = max(len(x) - 4, 1)
    cov = float(res @ res) / dof * np.linalg.pinv(J.T @ J)  # (c, R) in the DIC frame
    Q = dic.rotation if dic.rotation is not None else np.eye(3)  # DIC frame -> model frame
    return (Q @ cov[:3, :3] @ Q.T)[:2, :2]


def noise_model(
    exp: ExperimentData,
    dic: RegisteredDIC,
    steps: np.ndarray,
    *,
    force_noise: float | None = None,
    dic_noise: float | None = None,
) -> tuple[NoiseModel, np.ndarray]:
    """The noise of an experiment's data at ``steps`` (module docstring) and f_inf there.

    Parameters
    ----------
    exp : ExperimentData
        The experiment.
    dic : RegisteredDIC
        Its DIC data in the model frame.
    steps : numpy.ndarray
        The steps used (1..N).
    force_noise : float, optional
        Declared force noise (relative, one reading), replacing the one measured from the data.
    dic_noise : float, optional
        Declared DIC noise (mm, every direction), replacing the one measured from the data.

    Returns
    -------
    noise : NoiseModel
        The noise and where each part came from.
    f_inf : numpy.ndarray
        The static force at the steps (eq. 9), mN.
    """
    sd, f_inf, force_source = force_noise_per_step(exp, steps, force_noise)
    if dic_noise is not None:
        dic_sd, dic_source = np.full(3, float(dic_noise)), f"declared: {dic_noise:g} mm"
    else:
        deepest = int(np.max(steps)) - 1
        dic_sd = dic_noise_mm(dic.xyz[:, :2], dic.u[deepest])
        dic_source = f"measured from the DIC data at step {deepest + 1} (local quadratics, robust spread)"
    cov = _origin_covariance(exp, dic)
    reg_source = (
        f"the sphere fit of {len(exp.indenter_xyz)} indenter points "
        f"(residual {dic.sphere_rms:.3g} mm RMS): the indentation point's standard error"
    )
    return NoiseModel(sd, force_source, dic_sd, dic_source, cov, reg_source), f_inf
