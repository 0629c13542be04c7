"""The FE confirmation that ends a fit on a surrogate (paper 2.8.2 runs the inverse fit on the FE
model itself; here the FE model confirms the surrogate's fit, as in 3.4): one FE run with its exact
sensitivities at the fitted theta, the objective there, and how far one Gauss-Newton step from that
run would move each parameter, against the part of the fit's bound that is there to hold it: the
statistical half-width (eq. 6) combined in quadrature with the surrogate's own error (its held-out
errors pushed through the fit), where the fit carries that part.

A step inside that bound says the surrogate's minimum is the FE model's to within what the data
resolve and the surrogate's measured error; a step beyond it is a warning with numbers (the
surrogate misses the FE model there by more than its bounds carry, and a fit on the FE stage,
``fe_stage="fit"``, is worth its minutes). A run that fails is said, and the surrogate's fit is kept.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import lsq_linear

from ...design.objective import Objective
from ...forward.predictor import Prediction
from ...forward.solver import SimulationError
from .inverse_fit import residuals_at

__all__ = ["FitConfirmation", "confirm_fit", "gauss_newton_step"]


@dataclass
class FitConfirmation:
    """One FE run at a surrogate's fit and the Gauss-Newton step it points to.

    Attributes
    ----------
    theta : numpy.ndarray
        Where the FE model ran: (c1, c5) kPa, and mu when fitted.
    parameters : tuple of str
        The names of theta's entries.
    F_surrogate : float
        The objective (eq. 4) at theta on the surrogate.
    statistical_pct : numpy.ndarray
        The fit's statistical 95 % half-widths of (c1, c5), percent (eq. 6), and of mu when fitted
        (infinite where the data do not bound it).
    F_fe : float or None
        The objective at theta on the FE model; None when the run failed.
    shift_pct : numpy.ndarray or None
        The move of each parameter one Gauss-Newton step from the FE run would make, percent
        (a parameter held at its range's end stays there); None when the run failed.
    wall_s : float
        Time of the run.
    error : str or None
        Why the run failed.
    residuals : numpy.ndarray or None
        The FE run's residuals (eq. 4), for the adequacy test of the FE model at the fit.
    jacobian : numpy.ndarray or None
        Their Jacobian with respect to log theta.
    prediction : Prediction or None
        The FE run's response.
    surrogate_pct : numpy.ndarray or None
        The surrogate's own error in the fit's bound, per parameter, percent (infinite for a
        parameter whose reported interval is its whole range); None: not carried.
    """

    theta: np.ndarray
    parameters: tuple[str, ...]
    F_surrogate: float
    statistical_pct: np.ndarray
    F_fe: float | None = None
    shift_pct: np.ndarray | None = None
    wall_s: float = 0.0
    error: str | None = None
    residuals: np.ndarray | None = field(default=None, repr=False)
    jacobian: np.ndarray | None = field(default=None, repr=False)
    prediction: Prediction | None = field(default=None, repr=False)
    surrogate_pct: np.ndarray | None = None

    @property
    def allowed_pct(self) -> np.ndarray:
        """The half-widths a Gauss-Newton shift is held to, percent.

        The statistical bound combined in quadrature with the surrogate's own error where carried.

        Returns
        -------
        numpy.ndarray
            One per entry of ``statistical_pct``.
        """
        if self.surrogate_pct is None:
            return self.statistical_pct
        return np.hypot(self.statistical_pct, self.surrogate_pct[: len(self.statistical_pct)])

    @property
    def shift_beyond_bound(self) -> list[str]:
        """The parameters whose Gauss-Newton shift exceeds :attr:`allowed_pct`."""
        if self.shift_pct is None:
            return []
        n = len(self.statistical_pct)
        return [
            k
            for k, shift, half in zip(self.parameters[:n], self.shift_pct[:n], self.allowed_pct, strict=True)
            if abs(shift) > half
        ]

    @property
    def warnings(self) -> list[str]:
        """A failed run, or a shift beyond the statistical bound, in words with the numbers."""
        if self.error is not None:
            return [
                f"the FE confirmation at {_named(self.parameters, self.theta)} failed ({self.error}); "
                "the surrogate's fit is kept unconfirmed"
            ]
        beyond = self.shift_beyond_bound
        if not beyond:
            return []
        held = (
            "statistical and the surrogate's own error" if self.surrogate_pct is not None else "statistical"
        )
        moves = ", ".join(
            f"{k} {self.shift_pct[j]:+.2f} % (bound +- {self.allowed_pct[j]:.2f} %, {held})"
            for j, k in enumerate(self.parameters[: len(self.statistical_pct)])
            if k in beyond
        )
        return [
            f"the FE confirmation disagrees with the surrogate's fit: one Gauss-Newton step from the FE run "
            f"moves {moves}, F = {self.F_fe:.4g} on the FE model against {self.F_surrogate:.4g} on the "
            "surrogate; the surrogate misses the FE model here by more than the bounds carry: fit with "
            "--fe-stage fit"
        ]

    def to_dict(self) -> dict:
        """fit.json's ``fe_confirmation``."""
        return {
            "theta": self.theta.tolist(),
            "parameters": list(self.parameters),
            "F_fe": self.F_fe,
            "F_surrogate": self.F_surrogate,
            "gauss_newton_shift_pct": None if self.shift_pct is None else self.shift_pct.tolist(),
            "statistical_pct": [float(v) if np.isfinite(v) else None for v in self.statistical_pct],
            "surrogate_pct": None
            if self.surrogate_pct is None
            else [float(v) if np.isfinite(v) else None for v in self.surrogate_pct],
            "allowed_pct": [float(v) if np.isfinite(v) else None for v in self.allowed_pct],
            "shift_beyond_bound": self.shift_beyond_bound,
            "wall_s": self.wall_s,
            "error": self.error,
        }


def confirm_fit(
    objective: Objective,
    fe,
    eta,
    theta,
    *,
    F_surrogate: float,
    statistical_pct,
    box: tuple[np.ndarray, np.ndarray] | None = None,
    surrogate_pct=None,
) -> FitConfirmation:
    """Run the FE model once at a surrogate's fit and measure the Gauss-Newton step from there.

    The step is delta = -(J^T J)^-1 J^T r in log theta (eq. 4's residuals r and their exact
    sensitivities J from the FE run), as :func:`inference.fit.inverse_fit.gauss_newton_refine` takes
    it, kept inside ``box`` (:func:`gauss_newton_step`: mu at or near its range's end, where the
    data barely move it, stays in the range and the others' step is the best one with it there).

    Parameters
    ----------
    objective : Objective
        The fit's objective (eq. 4, 5).
    fe : Predictor
        The FE model the surrogate emulates, over the fit's parameters, with sensitivities.
    eta : array_like
        The weights of eq. 5.
    theta : array_like
        The surrogate's fit: (c1, c5) kPa, and mu when fitted.
    F_surrogate : float
        The objective at theta on the surrogate.
    statistical_pct : array_like
        The fit's statistical 95 % half-widths of (c1, c5), percent, and of mu when fitted.
    box : tuple of numpy.ndarray, optional
        (lo, hi) of theta in the fit.
    surrogate_pct : array_like, optional
        The surrogate's own error in the fit's bound, per parameter, percent (infinite where the
        reported interval is the parameter's whole range); the shift is held to it and the
        statistical bound combined.

    Returns
    -------
    FitConfirmation
        The run's F, the step in percent, or the reason it failed.
    """
    theta = np.asarray(theta, float)
    out = FitConfirmation(
        theta, tuple(fe.parameters), float(F_surrogate), np.asarray(statistical_pct, float)[: theta.size]
    )
    if surrogate_pct is not None:
        out.surrogate_pct = np.asarray(surrogate_pct, float)[: theta.size]
    t0 = time.perf_counter()
    seen: dict = {}
    try:
        r, J = residuals_at(objective, fe, eta, theta, keep=seen)
    except (SimulationError, RuntimeError, ValueError) as exc:
        out.error, out.wall_s = f"{type(exc).__name__}: {exc}", time.perf_counter() - t0
        return out
    out.wall_s = time.perf_counter() - t0
    out.F_fe = float(r @ r)
    out.residuals, out.jacobian, out.prediction = r, J, seen.get("prediction")
    out.shift_pct = 100.0 * np.expm1(gauss_newton_step(r, J, theta, box))
    return out


def gauss_newton_step(r: np.ndarray, J: np.ndarray, theta: np.ndarray, box=None) -> np.ndarray:
    """The Gauss-Newton step in log theta, kept inside ``box``: argmin |r + J delta| with
    theta exp(delta) in the box (bounded linear least squares, :func:`scipy.optimize.lsq_linear`).

    Without a box, delta = -(J^T J)^-1 J^T r. A parameter whose unconstrained step would leave the
    box (mu, poorly fixed by the data, can be sent far past its range's end by a linearisation that
    holds only near the fit) ends on the box's edge, and the others' step is the best one with it
    there.

    Parameters
    ----------
    r : numpy.ndarray
        (m,) residuals (eq. 4).
    J : numpy.ndarray
        (m, p) their Jacobian with respect to log theta.
    theta : numpy.ndarray
        (p,) where they were evaluated.
    box : tuple of numpy.ndarray, optional
        (lo, hi) of theta.

    Returns
    -------
    numpy.ndarray
        (p,) delta; the step takes theta to theta exp(delta).
    """
    if box is None:
        return np.linalg.lstsq(J, -r, rcond=None)[0]
    lo, hi = (np.broadcast_to(np.asarray(b, float), theta.shape) for b in box)
    with np.errstate(divide="ignore"):
        lower = np.where(lo > 0, np.log(np.maximum(lo, 1e-300) / theta), -np.inf)
        upper = np.where(np.isfinite(hi), np.log(hi / theta), np.inf)
    lower, upper = np.minimum(lower, 0.0), np.maximum(upper, 0.0)  # theta itself inside, to round-off
    return lsq_linear(J, -r, bounds=(lower, upper), method="bvls").x


def _named(names: tuple[str, ...], theta: np.ndarray) -> str:
    return "(" + ", ".join(f"{k} = {v:.4g}" for k, v in zip(names, theta, strict=True)) + ")"
