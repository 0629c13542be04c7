"""Eq. 9: the relaxation of the force during one step's hold, f(t) = A exp(-b t) + f_inf, whose
f_inf is the step's static force."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import curve_fit

from .errors import ExperimentDataError

__all__ = ["RelaxationFit", "relaxation_fit"]


@dataclass(frozen=True)
class RelaxationFit:
    f_inf: float
    f_inf_std: float
    amplitude: float
    rate: float


def relaxation_fit(t: np.ndarray, f: np.ndarray) -> RelaxationFit:
    """Eq. 9 fitted to one step's hold: f(t) = A exp(-b t) + f_inf."""
    t, f = np.asarray(t, float), np.asarray(f, float)
    span = float(np.ptp(t))
    if span <= 0:
        raise ExperimentDataError("a relaxation fit needs readings at different times")
    p0 = (f[0] - f[-1], 3.0 / span, f[-1])
    try:
        popt, pcov = curve_fit(
            lambda t, a, b, c: a * np.exp(-b * t) + c,
            t - t.min(),
            f,
            p0=p0,
            bounds=([-np.inf, 1e-6 / span, -np.inf], [np.inf, 1e3 / span, np.inf]),
            maxfev=10000,
        )
    except RuntimeError as exc:
        raise ExperimentDataError(f"the relaxation fit (eq. 9) did not converge: {exc}") from exc
    err = np.sqrt(np.diag(pcov)) if np.all(np.isfinite(pcov)) else np.full(3, np.inf)
    return RelaxationFit(float(popt[2]), float(err[2]), float(popt[0]), float(popt[1]))
