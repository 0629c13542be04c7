"""Certainty bounds from the Hessian of the objective (paper eq. 6 to 8), in normalised parameters
theta_bar = theta / theta*.

Two Hessians (eq. 7):

* :func:`gauss_newton_term_hessians`: 2 J_k^T J_k per objective term from exact residual
  Jacobians (the embedded solver's sensitivities, or a surrogate's derivatives). At theta_hat =
  theta* the residuals vanish, so this is the exact Hessian there.
* :func:`finite_difference_term_hessians`: central second differences of each F_k on any
  Predictor, over a 3^p stencil of step ``h`` in theta_bar (the authors' code does this on the
  campaign grid).

Because F = sum eta_k F_k, H(eta) = sum eta_k H_k (:func:`combine`). Bounds: theta_i = theta_hat_i
+- s sqrt(2 H^-1_ii) (eq. 6), printed as percent of theta_hat_i; s fixed at the design stage or
from the F distribution (eq. 8).
"""

from __future__ import annotations

import itertools

import numpy as np
from scipy import stats

from .objective import TERMS, Objective, check_weights

#: What a design-stage bound (eq. 6 at a given noise level s) holds, as the design commands say it.
DESIGN_BOUNDS_INCLUDE = (
    "eq. 6 at the noise level s given (design stage): measurement noise only; no model error (mesh, "
    "contact, surrogate), which `indent-studio design error-budget` measures"
)


def gauss_newton_term_hessians(objective: Objective, prediction, theta_star: np.ndarray) -> np.ndarray:
    """H_k = 2 J_k^T J_k (4, p, p) in theta_bar, from the Jacobians of a one-point Prediction."""
    if prediction.force_jacobian is None:
        raise ValueError("the prediction carries no Jacobian: use the embedded solver with sensitivities")
    scale = np.asarray(theta_star, float)
    jacs = objective.term_jacobians(prediction.force_jacobian[:1], prediction.displacement_jacobian[:1])
    return np.stack([2.0 * (j[0] * scale).T @ (j[0] * scale) for j in jacs])


def stencil(p: int, h) -> np.ndarray:
    """The 3^p central-difference stencil in theta_bar offsets (3^p, p); ``h`` a step for all
    axes or one per axis."""
    steps = np.broadcast_to(np.asarray(h, float), (p,))
    return np.array(list(itertools.product((-1.0, 0.0, 1.0), repeat=p))) * steps


#: The spacing of the paper's 25 x 31 grid in theta_bar at theta* = (10, 350) kPa: the step the
#: authors' code differentiates with.
PAPER_GRID_STEP = (20.0 / 24.0 / 10.0, (578.0 - 82.5) / 30.0 / 350.0)


def finite_difference_term_hessians(
    objective: Objective, predictor, theta_star: np.ndarray, h=0.02
) -> np.ndarray:
    """H_k (4, p, p) in theta_bar by central second differences of F_k over the 3^p stencil of
    step ``h`` (one for all parameters, or one per parameter, e.g. :data:`PAPER_GRID_STEP`)."""
    theta_star = np.asarray(theta_star, float)
    p = len(theta_star)
    if np.size(h) not in (1, p):
        raise ValueError(f"finite-difference steps: give one, or one per parameter ({p}), got {np.size(h)}")
    steps = np.broadcast_to(np.asarray(h, float), (p,))
    if np.any(~np.isfinite(steps)) or np.any(steps <= 0) or np.any(steps >= 1):
        raise ValueError(f"finite-difference steps must lie in (0, 1) in theta/theta*, got {steps.tolist()}")
    offsets = stencil(p, steps)
    pred = predictor.predict(theta_star * (1.0 + offsets))
    F = objective.terms(pred)  # (3^p, 4)
    index = {tuple(np.round(o / steps).astype(int)): i for i, o in enumerate(offsets)}

    def at(**where: int) -> np.ndarray:
        """F at the stencil point with offsets {axis: -1 | 0 | 1}, zero elsewhere."""
        k = [0] * p
        for axis, v in where.items():
            k[int(axis[1:])] = v
        return F[index[tuple(k)]]

    H = np.zeros((4, p, p))
    for i in range(p):
        H[:, i, i] = (at(**{f"a{i}": 1}) - 2 * at() + at(**{f"a{i}": -1})) / steps[i] ** 2
        for j in range(i + 1, p):
            ai, aj = f"a{i}", f"a{j}"
            cross = (
                at(**{ai: 1, aj: 1}) - at(**{ai: 1, aj: -1}) - at(**{ai: -1, aj: 1}) + at(**{ai: -1, aj: -1})
            )
            H[:, i, j] = H[:, j, i] = cross / (4 * steps[i] * steps[j])
    return H


def combine(term_hessians: np.ndarray, eta) -> np.ndarray:
    """The Hessian of the combined objective, H(eta) = sum_k eta_k H_k (eq. 5, 7).

    Parameters
    ----------
    term_hessians : numpy.ndarray
        (4, p, p) Hessians H_k of the four objectives (force, u1, u2, u3; eq. 4a, 4b).
    eta : array_like
        The four weights (eq. 5), checked by :func:`check_weights`.

    Returns
    -------
    numpy.ndarray
        (p, p) H(eta).

    Examples
    --------
    >>> import numpy as np
    >>> from indentation_studio.design import combine
    >>> H = np.stack([np.eye(2) * (k + 1) for k in range(4)])
    >>> combine(H, (0.45, 0.35, 0.2, 0.0))
    array([[1.75, 0.  ],
           [0.  , 1.75]])
    """
    return np.einsum("k,kij->ij", check_weights(eta), term_hessians)


def bounds_pct(H: np.ndarray, s: float) -> np.ndarray:
    """Certainty bounds of eq. 6 in percent of theta_hat: 100 s sqrt(2 (H^-1)_ii).

    Parameters
    ----------
    H : numpy.ndarray
        (p, p) Hessian of the objective at theta_hat (eq. 7), in normalised parameters
        theta / theta* (module docstring).
    s : float
        The statistical factor of eq. 8 (the paper takes 0.05).

    Returns
    -------
    numpy.ndarray
        (p,) half-widths, percent; inf for every parameter where H is singular (or its condition
        number exceeds 1e14, or a diagonal of H^-1 is not positive).

    Raises
    ------
    ValueError
        If ``s`` is not a positive number.

    Examples
    --------
    >>> import numpy as np
    >>> from indentation_studio.design import bounds_pct
    >>> bounds_pct(np.array([[2.07, -0.12], [-0.12, 0.07]]), 0.05).round(1)  # H of eq. 14
    array([ 5.2, 28.2])
    """
    if not (np.isfinite(s) and s > 0):
        raise ValueError(f"s must be a positive number, got {s!r}")
    try:
        inv = np.linalg.inv(H)
    except np.linalg.LinAlgError:
        return np.full(len(H), np.inf)
    d = np.diag(inv)
    if np.linalg.cond(H) > 1e14 or np.any(d <= 0):
        return np.full(len(H), np.inf)
    return 100.0 * s * np.sqrt(2.0 * d)


def s_from_data(F_hat: float, n: int, p: int = 2, alpha: float = 0.05) -> float:
    """The statistical factor s of eq. 8: s^2 = p / (n - p) F_{p, n-p}^{1-alpha} F(theta_hat).

    Parameters
    ----------
    F_hat : float
        The objective at the fit, F(theta_hat).
    n : int
        Number of data points.
    p : int, default 2
        Number of parameters.
    alpha : float, default 0.05
        The F distribution's quantile is at 1 - alpha.

    Returns
    -------
    float
        s.

    Raises
    ------
    ValueError
        If ``n <= p``.
    """
    if n <= p:
        raise ValueError(f"eq. 8 needs more data points than parameters (n = {n}, p = {p})")
    return float(np.sqrt(p / (n - p) * stats.f.ppf(1.0 - alpha, p, n - p) * F_hat))


def s_for_parameters(s: float, n: int, p_from: int, p_to: int, alpha: float = 0.05) -> float:
    """Eq. 8's s of a fit with ``p_from`` parameters read for ``p_to`` of them (the same F_hat and
    n): s sqrt(p_to F_{p_to, n-p_to} (n - p_from) / (p_from F_{p_from, n-p_from} (n - p_to))).
    The bounds of (c1, c5) with mu known at a fit of (c1, c5, mu) are the projection of a 2-D
    region, not of the 3-D one: with p = 3's s they would be about 14 % too wide."""
    if n <= max(p_from, p_to):
        raise ValueError(f"eq. 8 needs more data points than parameters (n = {n}, p = {p_from}, {p_to})")
    ratio = (p_to / (n - p_to) * stats.f.ppf(1.0 - alpha, p_to, n - p_to)) / (
        p_from / (n - p_from) * stats.f.ppf(1.0 - alpha, p_from, n - p_from)
    )
    return float(s * np.sqrt(ratio))


def term_names() -> tuple[str, ...]:
    return TERMS
