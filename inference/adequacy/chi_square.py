"""The chi-square test of a fit's residuals against the noise the data carry, and its verdict.

The model is compared as the data are seen: its own field sampled at the DIC points and put
through the same planes (what a plane makes of a curved field is no noise). Whitening
``z = L^-1 r`` with ``L L^T`` that covariance (steps independent), the statistic is the minimum
of ``z^T z`` over theta to first order, one generalised least-squares step from the fit: the fit
minimised the unwhitened sum, and can have moved theta to absorb part of a systematic
difference."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from ..experiment.processing import (
    NodeInterpolation,
)
from .noise import NoiseModel

__all__ = ["ALPHA", "CANNOT_EXPLAIN", "Adequacy", "chi_square_test"]

#: A fit whose statistic lies beyond this upper tail of its chi-square distribution is flagged.
ALPHA = 1e-3

#: What a flagged fit says.
CANNOT_EXPLAIN = "the model cannot explain these data; its bounds are not meaningful"


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
    field_error : dict or None
        The high fidelity's field error the covariance held (its table's file, meshes and
        points; :mod:`inference.adequacy.field_error`), None where none was.
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
    field_error: dict | None = None  # the high fidelity's field error in the covariance, where it was

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
        held = ""
        if self.field_error:
            fe = self.field_error
            held = (
                f"; {fe['coarse_mesh']}'s field error against {fe['fine_mesh']} "
                f"(measured at {fe['points']} points) held in the covariance"
            )
        return (
            f"{head}: chi-square {self.statistic:.4g} on {self.dof} degrees of freedom "
            f"({self.ratio:.3g} per degree), p = {self.p_value:.3g} (flagged below {self.alpha:g}); "
            f"largest per point: {worst[0]} ({worst[1]['statistic'] / worst[1]['n']:.3g}){names}{held}"
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
            "field_error": self.field_error,
            "message": self.message(),
        }


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
    field_variance: np.ndarray | None = None,
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
    field_variance : numpy.ndarray, optional
        (steps used, measured nodes, 3) the variance (mm^2) of the model's own field error at
        each node and step (a discretisation error measured between mesh levels), independent
        between nodes: added to the DIC covariance of each step.

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
        C = noise.dic_sd_mm[j] ** 2 * (W @ W.T).toarray() + 1e-18 * np.eye(W.shape[0])
        # the model's field error makes each step's covariance its own; else one for all steps
        v = None if field_variance is None else np.asarray(field_variance, float)[:, keep, j]
        factor = cho_factor(C, lower=True) if v is None else None
        B = gradients[:, keep, j, :] @ L_origin  # (s, kept, 2)
        statistic = 0.0
        for k in range(s):
            if v is not None:
                factor = cho_factor(C + np.diag(v[k]), lower=True)
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
