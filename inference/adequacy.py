"""Model adequacy: can the fitted model explain the data within their measurement noise?

The bounds of eq. 6 to 8 take s from the fit's own residuals, so a model that misses the data
(the wrong contact, a composite fitted as homogeneous, a force scale off) still gets narrow
bounds. Here the fit's residuals are whitened by the noise the data carry and summed into a
chi-square statistic with n - p degrees of freedom (n the data points the fit used, p the
fitted parameters); beyond its upper 0.1 % tail (``ALPHA``) the fit is flagged: the model
cannot explain these data, and its bounds are not meaningful.

The noise model:

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
  model explains the data within the noise and within what the model says it does not know.

The model is compared as the data are seen: its own field sampled at the DIC points and put
through the same planes (what a plane makes of a curved field is no noise). Whitening
``z = L^-1 r`` with ``L L^T`` that covariance (steps independent), the statistic is the minimum
of ``z^T z`` over theta to first order, one generalised least-squares step from the fit: the fit
minimised the unwhitened sum, and can have moved theta to absorb part of a systematic
difference. The parameters that sit at an end of their range are named and, where the fit is
flagged, mu identified narrowly while the model misses (mu on a composite: it absorbs model
error).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy import stats
from scipy.linalg import cho_factor, cho_solve

from ..forward.convergence.mesh_study import top_field_interpolator
from .budgets.model_error import has_high_fidelity_level, residual_changes
from .experiment.data import ExperimentData
from .experiment.errors import ExperimentDataError
from .experiment.processing import (
    NodeInterpolation,
    RegisteredDIC,
    _noise_neighbours,
    fit_sphere,
    node_interpolation,
)
from .experiment.relaxation import relaxation_fit

__all__ = [
    "ALPHA",
    "Adequacy",
    "NoiseModel",
    "chi_square_test",
    "dic_noise_mm",
    "force_noise_per_step",
    "model_adequacy",
    "noise_model",
]

#: A fit whose statistic lies beyond this upper tail of its chi-square distribution is flagged.
ALPHA = 1e-3

#: What a flagged fit says.
CANNOT_EXPLAIN = "the model cannot explain these data; its bounds are not meaningful"


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


@dataclass
class Adequacy:
    """The chi-square test of a fit: can the model explain the data within their noise.

    Attributes
    ----------
    statistic : float
        The whitened sum of squares.
    dof : int
        Its degrees of freedom.
    p_value : float
        The chi-square test's p-value.
    n : int
        Data points with noise and weight.
    p : int
        Parameters fitted.
    terms : dict of str to dict
        force, ux, uy, uz at the fit; registration, refit: what they take off.
    noise : NoiseModel
        The noise used.
    force_sd_pct : float
        Median force noise in percent of f_inf.
    named : list of dict
        ``{"parameter", "reason"}`` named when flagged.
    alpha : float
        The test's level: flagged when ``p_value < alpha``.
    """

    statistic: float
    dof: int
    p_value: float
    n: int
    p: int
    terms: dict[str, dict]  # force, ux, uy, uz at the fit; registration, refit: what they take off
    noise: NoiseModel
    force_sd_pct: float  # median force noise in percent of f_inf
    named: list[dict] = field(default_factory=list)  # {"parameter", "reason"}
    alpha: float = ALPHA

    @property
    def flagged(self) -> bool:
        """Whether the test rejects the model: ``p_value < alpha``."""
        return bool(self.p_value < self.alpha)

    @property
    def ratio(self) -> float:
        """The statistic over its degrees of freedom (1 on average where the model fits)."""
        return self.statistic / self.dof

    def message(self) -> str:
        """One line: the flag (or not) with its numbers."""
        head = CANNOT_EXPLAIN if self.flagged else "the model explains these data within their noise"
        data = [(k, v) for k, v in self.terms.items() if v["n"]]  # not the registration's, the refit's
        worst = max(data, key=lambda kv: kv[1]["statistic"] / kv[1]["n"])
        names = "".join(f"; {d['parameter']}: {d['reason']}" for d in self.named)
        return (
            f"{head}: chi-square {self.statistic:.4g} on {self.dof} degrees of freedom "
            f"({self.ratio:.3g} per degree), p = {self.p_value:.3g} (flagged below {self.alpha:g}); "
            f"largest per point: {worst[0]} ({worst[1]['statistic'] / worst[1]['n']:.3g}){names}"
        )

    def to_dict(self) -> dict:
        """The test as fit.json records it.

        Returns
        -------
        dict
            The flag, statistic, degrees of freedom, p-value, level, terms, noise and message.
        """
        noise = self.noise.to_dict() | {"force_sd_pct_median": self.force_sd_pct}
        return {
            "flagged": self.flagged,
            "statistic": self.statistic,
            "dof": self.dof,
            "p_value": self.p_value,
            "alpha": self.alpha,
            "data_points": self.n,
            "parameters": self.p,
            "per_degree": self.ratio,
            "terms": self.terms,
            "noise": noise,
            "named_parameters": self.named,
            "message": self.message(),
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


# ------------------------------------------------------------------------------- the test
def chi_square_test(
    residuals: np.ndarray,
    objective,
    eta,
    *,
    noise: NoiseModel,
    plan: NodeInterpolation,
    gradients: np.ndarray,
    p: int,
    operator_bias: np.ndarray | None = None,
    jacobian: np.ndarray | None = None,
    model_directions: np.ndarray | None = None,
    alternatives: np.ndarray | None = None,
) -> tuple[float, int, dict[str, dict]]:
    """The chi-square statistic of a fit: the whitened sum of squares of its residuals.

    The ``residuals`` are the vector of eq. 5 (sqrt(eta_k) r_k over force, ux, uy, uz) on
    ``objective``, whitened with ``noise``; the DIC part through ``plan`` (the
    interpolation the objective's data came from) and the registration through ``gradients``
    (steps used, measured nodes, 3 directions, 2: d u / d x, y of the data at the nodes).
    ``operator_bias`` (steps used, measured nodes, 3) is what the interpolation makes of the
    model's own field at the nodes less that field (:func:`operator_bias`): the model seen
    through the same planes as the data. With the fit's ``jacobian`` (residuals by log theta)
    the statistic is the minimum over theta of the linearised whitened sum, one generalised
    least-squares step from the fit (the fit minimised the unwhitened sum, which can move theta
    to absorb part of a systematic difference the whitened one would not): what is chi-square
    with n - p degrees of freedom where the model and the noise are right. A node value that
    carries no noise (ux on the x = 0 symmetry plane, uy on y = 0: mirror images cancel) carries
    no information either and is left out. Returns the statistic, its degrees of freedom (data
    points with noise and weight minus ``p``) and each term's share (at the fit).

    Parameters
    ----------
    residuals : numpy.ndarray
        The fit's residual vector of eq. 5.
    objective : Objective
        The fit's objective.
    eta : array_like
        The weights of eq. 5.
    noise : NoiseModel
        The measurement noise.
    plan : NodeInterpolation
        The interpolation the objective's DIC data came from.
    gradients : numpy.ndarray
        (steps used, measured nodes, 3, 2) d u / d x, y of the data at the nodes.
    p : int
        Parameters fitted.
    operator_bias : numpy.ndarray, optional
        (steps used, measured nodes, 3) the interpolation of the model's field less that field.
    jacobian : numpy.ndarray, optional
        The fit's d residuals / d log theta.
    model_directions : numpy.ndarray, optional
        (k, residuals) the model's own stated uncertainty in residual space, one standard
        deviation per row (a multi-fidelity surrogate's discrepancy: its predictive covariance
        factor moved through eq. 5, :func:`inference.budgets.model_error.residual_changes`); a low-rank
        term of the covariance beside the registration's, by the same Woodbury identity.
    alternatives : numpy.ndarray, optional
        (a, residuals) the residual vector as other readings of the same data would make it
        (the DIC points registered about other indentation points within the declared
        registration uncertainty, :func:`registration_alternatives`): the statistic is the least
        over the residuals and these, and two degrees of freedom go to that choice.

    Returns
    -------
    statistic : float
        The whitened sum of squares.
    dof : int
        Its degrees of freedom.
    terms : dict of str to dict
        Each term's share at the fit.

    Raises
    ------
    ValueError
        If the residual vector does not match the objective.
    """
    e = np.asarray(eta, float)
    s = len(objective.steps)
    measured = objective.measured
    m = int(measured.sum())
    r = np.asarray(residuals, float)
    if r.size != s + 3 * s * m:
        raise ValueError(f"the residual vector has {r.size} entries; the objective makes {s + 3 * s * m}")
    J = np.zeros((r.size, 0)) if jacobian is None else np.asarray(jacobian, float).reshape(r.size, -1)
    G = np.zeros((r.size, 0)) if model_directions is None else np.asarray(model_directions, float).T
    if G.shape[0] != r.size:
        raise ValueError(f"model_directions have {G.shape[0]} entries; the residual vector {r.size}")
    A = np.zeros((r.size, 0)) if alternatives is None else np.asarray(alternatives, float).T
    if A.shape[0] != r.size:
        raise ValueError(f"alternatives have {A.shape[0]} entries; the residual vector {r.size}")
    nJ = J.shape[1]
    q0 = 1 + nJ + A.shape[1]  # the residuals, their derivatives, other readings; then the model's directions
    candidates = [0, *range(1 + nJ, q0)]  # the residual vectors the statistic is the least of
    R = np.column_stack([r, J, A, G])  # all transformed alike
    scale = objective.displacement_residual_scale()[measured]  # (m, 3)
    L_origin = np.linalg.cholesky(noise.origin_cov_mm2 + 1e-30 * np.eye(2))
    q = R.shape[1]
    gram = np.zeros((q, q))  # R^T D^-1 R
    BtDR, BtDB = np.zeros((2, q)), np.zeros((2, 2))
    terms: dict[str, dict] = {}
    if e[0] > 0:
        z = R[:s] / np.sqrt(e[0]) * (objective.force_scale / noise.force_sd_mN)[:, None]  # whitened
        gram += z.T @ z
        terms["force"] = {"statistic": float(z[:, 0] @ z[:, 0]), "n": int(s)}
    for j, name in enumerate(("ux", "uy", "uz")):
        if e[j + 1] <= 0:
            continue
        part = R[s + j * s * m : s + (j + 1) * s * m].reshape(s, m, q)
        with np.errstate(divide="ignore", invalid="ignore"):
            du = part / (np.sqrt(e[j + 1]) * scale[:, j])[None, :, None]  # (s, m, q): model - data, mm
        if operator_bias is not None:
            du[..., candidates] += operator_bias[:, :, j][..., None]
        W = plan.matrix(j)[measured]  # (m, points), sparse
        norm = np.sqrt(np.asarray(W.multiply(W).sum(axis=1)).ravel())
        keep = (norm > 1e-8 * norm.max()) & np.isfinite(scale[:, j]) & (scale[:, j] > 0)
        W, du = W[keep], du[:, keep]
        C = noise.dic_sd_mm[j] ** 2 * (W @ W.T).toarray()
        factor = cho_factor(C + 1e-18 * np.eye(len(C)), lower=True)
        B = gradients[:, keep, j, :] @ L_origin  # (s, kept, 2)
        statistic = 0.0
        for k in range(s):
            Dinv_R = cho_solve(factor, du[k])
            gram += du[k].T @ Dinv_R
            statistic += float(du[k, :, 0] @ Dinv_R[:, 0])
            BtDR += B[k].T @ Dinv_R
            BtDB += B[k].T @ cho_solve(factor, B[k])
        terms[name] = {"statistic": statistic, "n": int(du.shape[0] * du.shape[1])}
    # (D + U U^T)^-1 by Woodbury, U = [B, G]: the registration's rank-two term and the model's own
    RDR = gram[:q0, :q0]
    Q_reg = RDR - BtDR[:, :q0].T @ np.linalg.solve(np.eye(2) + BtDB, BtDR[:, :q0])
    UtDR = np.vstack([BtDR[:, :q0], gram[q0:, :q0]])
    UtDU = np.block([[BtDB, BtDR[:, q0:]], [BtDR[:, q0:].T, gram[q0:, q0:]]])
    Q = RDR - UtDR.T @ np.linalg.solve(np.eye(len(UtDU)) + UtDU, UtDR)
    jcols = list(range(1, 1 + nJ))
    QJ = Q[np.ix_(jcols, jcols)]

    def refitted(c: int) -> float:  # the minimum over theta of the linearised whitened sum
        if not jcols:
            return float(Q[c, c])
        return float(Q[c, c] - Q[c, jcols] @ np.linalg.lstsq(QJ, Q[jcols, c], rcond=None)[0])

    values = [refitted(c) for c in candidates]
    best = int(np.argmin(values))
    at_fit = float(Q[0, 0])
    statistic = values[best]
    terms["registration"] = {"statistic": float(Q_reg[0, 0] - gram[0, 0]), "n": 0}
    if G.shape[1]:
        terms["model_uncertainty"] = {"statistic": float(Q[0, 0] - Q_reg[0, 0]), "n": 0}
    if jcols:
        terms["refit"] = {"statistic": values[0] - at_fit, "n": 0}
    if A.shape[1]:
        terms["registration_profile"] = {"statistic": statistic - values[0], "n": 0, "reading": best}
    n = int(sum(t["n"] for t in terms.values()))
    return max(statistic, 0.0), n - p - (2 if A.shape[1] else 0), terms


#: The indentation points the registration profile tries: rings at these fractions of the declared
#: registration uncertainty, in this many directions.
PROFILE_RINGS = (0.25, 0.5, 0.75, 1.0)
PROFILE_DIRECTIONS = 12


def registration_alternatives(
    objective, dic: RegisteredDIC, used_steps: np.ndarray, eta, registration_mm: float
) -> np.ndarray:
    """(a, residuals): how eq. 5's residual vector changes when the DIC points are registered about
    another indentation point within ``registration_mm`` (rings at :data:`PROFILE_RINGS` of it, in
    :data:`PROFILE_DIRECTIONS` directions).

    The data stay what they are; the whole processing runs again (the quarter's folding about the
    point, the nearest points, the planes), so what a misregistration does next to the symmetry
    planes and to which points a node sees is in it, which no gradient at the nodes holds. A node
    that has no plane about one of the points keeps its value.

    Parameters
    ----------
    objective : Objective
        The fit's objective (its data came from ``dic`` by the same processing).
    dic : RegisteredDIC
        The DIC data in the model frame.
    used_steps : numpy.ndarray
        The experiment's steps used (1..N).
    eta : array_like
        The weights of eq. 5.
    registration_mm : float
        The declared registration uncertainty, mm.

    Returns
    -------
    numpy.ndarray
        (rings x directions, residuals) the change of the residual vector for each point.
    """
    e = np.asarray(eta, float)
    s, measured = len(objective.steps), objective.measured
    node_xy = np.asarray(objective.top_xyz)[:, :2]
    steps = np.asarray(objective.steps, int)  # 0-based
    scale = objective.displacement_residual_scale()[measured]  # (m, 3)

    def nodes_of(shift: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        plan = node_interpolation(replace(dic, xyz=dic.xyz - shift), node_xy, used_steps=used_steps)
        u = np.nan_to_num(dic.u[steps][:, plan.points])
        values = np.stack([(plan.matrix(j) @ u[..., j].T).T for j in range(3)], axis=-1)
        return values[:, measured], plan.measured[measured]

    base = np.asarray(objective.displacement, float)[steps][:, measured]  # the same processing, unmoved
    out = []
    for ring in PROFILE_RINGS:
        for angle in np.arange(PROFILE_DIRECTIONS) * 2.0 * np.pi / PROFILE_DIRECTIONS:
            shift = ring * registration_mm * np.array([np.cos(angle), np.sin(angle), 0.0])
            moved, seen = nodes_of(shift)
            D = np.where(seen[None, :, None], moved - base, 0.0)  # (s, m, 3), mm
            dr = np.zeros(s + 3 * s * int(measured.sum()))
            for j in range(3):
                if e[j + 1] > 0:
                    part = -D[..., j] * np.sqrt(e[j + 1]) * scale[:, j][None, :]
                    dr[s + j * s * part.shape[1] : s + (j + 1) * s * part.shape[1]] = np.nan_to_num(
                        part
                    ).ravel()
            out.append(dr)
    return np.array(out)


def operator_bias(
    prediction, plan: NodeInterpolation, dic: RegisteredDIC, steps: np.ndarray, measured: np.ndarray
) -> np.ndarray:
    """(steps used, measured nodes, 3): the model's top field (``prediction``, one point) sampled
    at the DIC points (its quarter unfolded by symmetry, as the data are) and interpolated to the
    nodes by the planes the data went through, less its values at the nodes: what the
    interpolation itself makes of a curved field, which is no noise (without it data made by the
    fitted model itself fail the test where the field bends, next to the indenter)."""
    top = np.asarray(prediction.top_xyz, float)
    field = np.asarray(prediction.displacement[0], float)[np.asarray(steps, int) - 1]  # (s, nodes, 3)
    xy = dic.xyz[plan.points, :2]
    interp = top_field_interpolator(top, np.moveaxis(field, 0, 1))
    at = np.moveaxis(interp(np.minimum(np.abs(xy), top[:, :2].max(axis=0))), 0, 1)  # (s, points, 3)
    at[..., 0] *= np.sign(xy[:, 0])
    at[..., 1] *= np.sign(xy[:, 1])
    seen = np.stack([(plan.matrix(j) @ at[..., j].T).T for j in range(3)], axis=-1)  # (s, nodes, 3)
    return (seen - field)[:, measured]


def _gradients(
    plan: NodeInterpolation, dic: RegisteredDIC, steps: np.ndarray, measured: np.ndarray
) -> np.ndarray:
    """(steps, measured nodes, 3, 2): the in-plane gradient of the DIC field at the nodes (the
    interpolating planes' slopes), what a shift of the indentation point moves each value by."""
    n_ok = len(plan.points)
    u = np.nan_to_num(dic.u[np.asarray(steps, int) - 1][:, plan.points])  # (s, n_ok, 3)
    U = u[:, plan.neighbours % n_ok] * plan.signs[None]  # (s, nodes, k, 3)
    g = np.einsum("nak,snkd->snda", plan.planes[:, 1:, :], U)  # (s, nodes, 3, 2)
    return g[:, measured]


def _named(fr: dict, flagged: bool, at_ends: list[dict]) -> list[dict]:
    """The parameters a fit names: those at a range end and, when it is flagged, mu fitted
    (``fr``: fit.json's 'friction') while the model misses the data: identified (a narrow
    interval: it absorbs model error) or pressed against an end of its range (its interval
    reaching it: the fit moves it as far as it may to take up the misfit)."""
    named = list(at_ends)
    if not flagged or "mu" not in fr or any(d["parameter"] == "mu" for d in named):
        return named
    lo, hi = fr["mu_interval"]
    ends = [side for side, reached in (fr.get("mu_reaches_range_end") or {}).items() if reached]
    if fr.get("mu_identified"):
        reason = (
            f"identified at {fr['mu']:.3g} (95 % within [{lo:.3g}, {hi:.3g}]) while the model misses the "
            "data: mu absorbs model error here, its value is not a friction coefficient"
        )
    elif ends:
        reason = (
            f"fitted at {fr['mu']:.3g}, its 95 % interval [{lo:.3g}, {hi:.3g}] reaching the range's "
            f"{' and '.join(ends)} end while the model misses the data: mu moves to take up the misfit, "
            "its value is not a friction coefficient"
        )
    else:
        return named
    return [*named, {"parameter": "mu", "reason": reason}]


def model_adequacy(
    inputs,
    fit,
    *,
    force_noise: float | None = None,
    dic_noise: float | None = None,
    at_ends: list[dict] | None = None,
    friction: dict | None = None,
    registration_mm: float = 0.0,
    model_directions: np.ndarray | None = None,
) -> Adequacy:
    """The adequacy test of ``fit`` (a :class:`inference.fit.inverse_fit.FitResult` carrying its
    residuals) on ``inputs`` (:class:`inference.fit.inputs.FitInputs`): the chi-square statistic
    of its residuals whitened by the data's noise (module docstring), its degrees of freedom and
    p-value; flagged beyond the upper ``ALPHA`` tail. ``force_noise`` (relative, one reading) and
    ``dic_noise`` (mm) are declared levels; ``at_ends`` are parameters the caller found at a range
    end ({"parameter", "reason"}), named; ``friction`` (fit.json's 'friction') names mu when it
    was identified narrowly while the fit is flagged; ``registration_mm`` the declared registration
    uncertainty, profiled (:func:`registration_alternatives`); ``model_directions`` the model's own stated uncertainty
    in residual space (:func:`chi_square_test`)."""
    if fit.residuals is None:
        raise ValueError("the fit records no residuals: the adequacy test needs them")
    objective, exp, dic = inputs.objective, inputs.experiment, inputs.dic
    steps = np.asarray(objective.steps, int) + 1
    # the declared registration uncertainty: profiled over (the processing run again about other
    # indentation points) where the residual vector is known to it, else in the covariance
    alternatives = None
    if registration_mm > 0:
        alternatives = fit.residuals[None, :] + registration_alternatives(
            objective, dic, exp.used_steps, inputs.eta, registration_mm
        )
    noise, f_inf = noise_model(exp, dic, steps, force_noise=force_noise, dic_noise=dic_noise)
    plan = node_interpolation(dic, np.asarray(objective.top_xyz)[:, :2], used_steps=exp.used_steps)
    grads = _gradients(plan, dic, steps, objective.measured)
    bias = None
    if fit.prediction is not None:
        bias = operator_bias(fit.prediction, plan, dic, steps, objective.measured)
    statistic, dof, terms = chi_square_test(
        fit.residuals,
        objective,
        inputs.eta,
        noise=noise,
        plan=plan,
        gradients=grads,
        p=fit.theta.size,
        operator_bias=bias,
        jacobian=fit.jacobian,
        model_directions=model_directions,
        alternatives=alternatives,
    )
    p_value = float(stats.chi2.sf(statistic, dof)) if dof > 0 else float("nan")
    force_pct = float(np.median(100.0 * noise.force_sd_mN / np.abs(f_inf)))
    out = Adequacy(
        float(statistic),
        int(dof),
        p_value=p_value,
        n=dof + fit.theta.size,
        p=fit.theta.size,
        terms=terms,
        noise=noise,
        force_sd_pct=force_pct,
    )
    out.named = _named(friction or {}, out.flagged, at_ends or [])
    return out


def training_box_ends(model, theta) -> list[tuple[int, str]]:
    """The entries of ``theta`` at or beyond an end of the box ``model`` was trained on, within
    0.5 % (outside it a surrogate extrapolates): (index, ``lower`` or ``upper``); none for a
    Predictor without a training box. ``theta`` may be shorter than the model's parameters (mu held)."""
    scaler = getattr(model, "scaler", None)
    if scaler is None:
        return []
    out = []
    for j in range(min(np.size(theta), len(model.parameters))):
        lo, hi = float(scaler.lo[j]), float(scaler.hi[j])
        where = "lower" if theta[j] <= lo * 1.005 else "upper" if theta[j] >= hi * 0.995 else None
        if where is not None:
            out.append((j, where))
    return out


def parameters_at_ends(result) -> list[dict]:
    """The parameters of an :class:`inference.experiment_fit.ExperimentFit` that sit at an end of
    their range: mu on its range's limit, and c1, c5 (and mu) at or beyond the ends of the box
    the surrogate was trained on (within 0.5 %: outside it a surrogate extrapolates, and where the
    FE stage went there the surrogate's start says nothing of it)."""
    out = []
    theta = np.asarray(result.fit.theta, float)
    names = ("c1", "c5", "mu")
    fr = result._friction_dict() if result.friction.fits_mu else {}
    if fr.get("mu_at_limit"):
        out.append(
            {
                "parameter": "mu",
                "reason": f"on its range's {fr['mu_at_limit']} limit ({fr['mu']:.3g}; range {fr['mu_range']})",
            }
        )
    model = result.inputs.surrogate
    for j, where in training_box_ends(model, theta):
        name = model.parameters[j]
        if name == "mu" and out:
            continue
        lo, hi = float(model.scaler.lo[j]), float(model.scaler.hi[j])
        beyond = theta[j] < lo or theta[j] > hi
        stage = "the FE stage's fit" if result.refined else "the fit"
        out.append(
            {
                "parameter": names[j] if name not in names else name,
                "reason": (
                    f"{theta[j]:.4g} is {'beyond' if beyond else 'at'} the {where} end of the {model.kind} "
                    f"surrogate's training range [{lo:.4g}, {hi:.4g}] ({stage})"
                ),
            }
        )
    return out


def _model_directions(result) -> np.ndarray | None:
    """A multi-fidelity fit's discrepancy uncertainty at its fit, in residual space (one standard
    deviation a row): what the model states it does not know, which the test allows beside the
    noise. None for a surrogate without a high-fidelity level."""
    model, tested = result.inputs.surrogate, result.tested_fit
    if not has_high_fidelity_level(model) or tested.prediction is None:
        return None
    factor = model.discrepancy_covariance_factor(result._theta_in_surrogate())
    return residual_changes(result.inputs.objective, result.inputs.eta, tested.prediction, factor)


def fit_adequacy(
    result,
    *,
    force_noise: float | None = None,
    dic_noise: float | None = None,
    registration_mm: float = 0.0,
) -> tuple[Adequacy | None, str | None]:
    """The adequacy test of an :class:`inference.experiment_fit.ExperimentFit`'s final fit (its
    ``tested_fit``: the FE model's residuals at the fit when an FE confirmation ran), with
    the parameters it names, the declared registration uncertainty and, for a multi-fidelity
    surrogate, its discrepancy's uncertainty at the fit in the covariance; or None and why the test could not be made (the fit's residuals
    missing, a hold without a standard error and no noise declared, too few DIC points)."""
    try:
        fr = result._friction_dict() if result.friction.fits_mu else {}
        return (
            model_adequacy(
                result.inputs,
                result.tested_fit,
                force_noise=force_noise,
                dic_noise=dic_noise,
                at_ends=parameters_at_ends(result),
                friction=fr,
                registration_mm=registration_mm,
                model_directions=_model_directions(result),
            ),
            None,
        )
    except (ValueError, np.linalg.LinAlgError) as exc:
        return None, f"the adequacy test could not be made: {exc}"
