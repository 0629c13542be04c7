"""Objective weights eta on the simplex that shrink the certainty bounds (paper 2.6, Table 1).

H(eta) = sum eta_k H_k, so a weight search needs only the four term Hessians. Criteria on
H(eta)^-1 (in theta_bar): ``c1`` or ``c5`` (that parameter's bound), ``combined`` (sum of the
squared relative bounds, i.e. the trace; default), ``det`` (det H^-1, the ellipse's area).
scipy SLSQP on the simplex from several starts (the corners' mid-points and random ones).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from .certainty import bounds_pct, combine

#: The rows of Table 1 that do not come from an optimisation.
FIXED_ROWS = {"force only": (1.0, 0.0, 0.0, 0.0)}

#: The paper's Table 1 (theta* = {10, 350} kPa, s = 0.05): row, weights (force, ux, uy, uz),
#: bounds of c1 and c5 in percent.
PAPER_TABLE1 = (
    ("force only", (1.0, 0.0, 0.0, 0.0), 22.5, 210.2),
    ("deformation only", (0.0, 0.35, 0.35, 0.3), 12.8, 50.7),
    ("optimal for c1", (0.7, 0.3, 0.0, 0.0), 4.5, 29.8),
    ("optimal for c5", (0.4, 0.35, 0.25, 0.0), 5.4, 28.3),
    ("combined optimal", (0.45, 0.35, 0.2, 0.0), 5.2, 28.3),
)
#: The paper's H(theta*) for the combined weights (eq. 14), in theta_bar.
PAPER_HESSIAN = ((2.07, -0.12), (-0.12, 0.07))


@dataclass(frozen=True)
class WeightRow:
    name: str
    weights: tuple[float, ...]
    c1_pct: float
    c5_pct: float


def criterion_value(H: np.ndarray, criterion: str, parameters: tuple[str, ...] = ("c1", "c5")) -> float:
    """The scalar a weight search minimises, from H(eta) in theta_bar."""
    try:
        inv = np.linalg.inv(H)
    except np.linalg.LinAlgError:
        return np.inf
    if not np.all(np.isfinite(inv)) or np.any(np.diag(inv) <= 0) or np.linalg.cond(H) > 1e14:
        return np.inf
    if criterion in parameters:
        return float(inv[parameters.index(criterion)][parameters.index(criterion)])
    if criterion == "combined":
        return float(np.trace(inv))
    if criterion == "det":
        return float(np.linalg.det(inv))
    raise ValueError(f"unknown criterion {criterion!r}; use {', '.join(parameters)}, combined or det")


def optimise_weights(
    term_hessians: np.ndarray,
    criterion: str = "combined",
    starts: int = 12,
    seed: int = 0,
    allowed: np.ndarray | None = None,
) -> np.ndarray:
    """The weights eta (4,) on the simplex (eq. 5) that minimise ``criterion`` (SLSQP, several starts).

    Parameters
    ----------
    term_hessians : numpy.ndarray
        (4, p, p) term Hessians in theta_bar.
    criterion : str, default "combined"
        ``c1`` or ``c5`` (that diagonal of H^-1), ``combined`` (its trace) or ``det`` (its
        determinant).
    starts : int, default 12
        Starting points: the uniform weights and random ones.
    seed : int, default 0
        Seed of the random starts.
    allowed : numpy.ndarray, optional
        (4,) bool: which terms may get weight (e.g. displacements only).

    Returns
    -------
    numpy.ndarray
        (4,) the best weights found.
    """
    k = term_hessians.shape[0]
    allowed = np.ones(k, bool) if allowed is None else np.asarray(allowed, bool)
    idx = np.nonzero(allowed)[0]
    rng = np.random.default_rng(seed)

    def full(x: np.ndarray) -> np.ndarray:
        e = np.zeros(k)
        e[idx] = np.clip(x, 0.0, None)
        return e / e.sum() if e.sum() > 0 else np.full(k, 1.0 / k)

    def f(x: np.ndarray) -> float:
        v = criterion_value(combine(term_hessians, full(x)), criterion)
        return np.log(v) if np.isfinite(v) and v > 0 else 1e6

    x0s = [np.full(len(idx), 1.0 / len(idx))]
    x0s += [rng.dirichlet(np.ones(len(idx))) for _ in range(max(starts - 1, 0))]
    best, best_val = x0s[0], f(x0s[0])
    for x0 in x0s:
        res = minimize(
            f,
            x0,
            method="SLSQP",
            bounds=[(0.0, 1.0)] * len(idx),
            constraints=[{"type": "eq", "fun": lambda x: np.sum(x) - 1.0}],
            options={"ftol": 1e-12, "maxiter": 300},
        )
        if res.fun < best_val:
            best, best_val = res.x, res.fun
    return full(best)


def table1(term_hessians: np.ndarray, s: float = 0.05, criterion: str = "combined") -> list[WeightRow]:
    """The rows of the paper's Table 1 from the term Hessians: weights and their eq. 6 bounds.

    Force only; deformation only (best displacement-only weights for ``criterion``); optimal for
    c1; optimal for c5; ``criterion`` optimal.

    Parameters
    ----------
    term_hessians : numpy.ndarray
        (4, p, p) term Hessians in theta_bar.
    s : float, default 0.05
        The noise level of eq. 6.
    criterion : str, default "combined"
        What the last row (and the deformation-only row) minimise (:func:`optimise_weights`).

    Returns
    -------
    list of WeightRow
        Five rows: name, weights, ``c1_pct``, ``c5_pct``.
    """
    rows = []

    def row(name: str, eta: np.ndarray) -> WeightRow:
        b = bounds_pct(combine(term_hessians, eta), s)
        return WeightRow(name, tuple(float(v) for v in eta), float(b[0]), float(b[1]))

    rows.append(row("force only", np.array(FIXED_ROWS["force only"])))
    rows.append(
        row(
            "deformation only",
            optimise_weights(term_hessians, criterion, allowed=np.array([0, 1, 1, 1], bool)),
        )
    )
    rows.append(row("optimal for c1", optimise_weights(term_hessians, "c1")))
    rows.append(row("optimal for c5", optimise_weights(term_hessians, "c5")))
    rows.append(row(f"{criterion} optimal", optimise_weights(term_hessians, criterion)))
    return rows


@dataclass(frozen=True)
class ComparisonRow:
    """One row of Table 1: the paper's weights and bounds, ours at the paper's weights, and our
    own optimum for the same row."""

    name: str
    paper_weights: tuple[float, ...]
    paper_c1_pct: float
    paper_c5_pct: float
    c1_pct_at_paper_weights: float
    c5_pct_at_paper_weights: float
    weights: tuple[float, ...]
    c1_pct: float
    c5_pct: float


def compare_with_paper(
    term_hessians: np.ndarray, s: float = 0.05, criterion: str = "combined"
) -> list[ComparisonRow]:
    """Table 1 row by row: the paper's numbers beside ours at its weights and at our optimum.

    Parameters
    ----------
    term_hessians : numpy.ndarray
        (4, p, p) term Hessians in theta_bar.
    s : float, default 0.05
        The noise level of eq. 6.
    criterion : str, default "combined"
        What our optimum minimises (:func:`table1`).

    Returns
    -------
    list of ComparisonRow
        Per row: the paper's weights and bounds, ours at the paper's weights, our weights and
        bounds.
    """
    ours = table1(term_hessians, s, criterion)
    rows = []
    for (name, eta, p1, p5), opt in zip(PAPER_TABLE1, ours, strict=True):
        b = bounds_pct(combine(term_hessians, np.array(eta)), s)
        rows.append(
            ComparisonRow(
                name,
                eta,
                paper_c1_pct=p1,
                paper_c5_pct=p5,
                c1_pct_at_paper_weights=float(b[0]),
                c5_pct_at_paper_weights=float(b[1]),
                weights=opt.weights,
                c1_pct=opt.c1_pct,
                c5_pct=opt.c5_pct,
            )
        )
    return rows
