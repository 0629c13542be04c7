"""A baseline theta* before the experiment, from the constituents (paper 3.1, eq. 10, 11; supplement S3).

* :func:`rule_of_mixtures`: eq. 11a, 11b from the matrix's neo-Hookean shear modulus, the fibers'
  Mooney-Rivlin constants and the fiber volume fraction.
* :func:`parallel_fiber_stresses`: the equibiaxial stresses the rule of mixtures of the
  constituents' own stresses gives for continuous fibers (what an FE composite should approach).
* :func:`fit_neo_hookean_uniaxial`: the matrix's mu from uniaxial tension (or compression) data.
* :func:`fit_mooney_rivlin_uniaxial`: the fibers' (c1, c2) from uniaxial tension data.
* :func:`fit_equibiaxial`: (c1, c5) of eq. 2 from equibiaxial stress-stretch data (eq. 10a, 10b),
  e.g. the averaged stresses of a composite FE model (paper 2.9).

All stresses are Cauchy (true) stresses in kPa of an incompressible specimen; give
``nominal=True`` for force over reference area. Every fit returns the estimates with their
standard errors (scipy.optimize.curve_fit's covariance).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from scipy.optimize import curve_fit

from ..forward.material import equibiaxial_stress_incompressible


@dataclass(frozen=True)
class Fit:
    """Fitted parameters (by name, kPa), their standard errors and the RMS residual (kPa)."""

    values: dict[str, float]
    std_errors: dict[str, float]
    rms_kPa: float
    n_points: int


def rule_of_mixtures(
    mu_matrix: float, c1_fiber: float, c2_fiber: float, fiber_volume_fraction: float
) -> tuple[float, float]:
    """The homogeneous (c1, c5) of a fiber composite by the rule of mixtures (eq. 11).

    c1 = mu_m / 2 (eq. 11a), c5 = FVF (c1_f + c2_f) + (1 - FVF) c1 (eq. 11b).

    Parameters
    ----------
    mu_matrix : float
        Shear modulus of the matrix, kPa.
    c1_fiber, c2_fiber : float
        Mooney-Rivlin constants of the fibers, kPa.
    fiber_volume_fraction : float
        FVF, in (0, 1).

    Returns
    -------
    tuple of float
        (c1, c5), kPa.

    Raises
    ------
    ValueError
        If the matrix modulus is not positive, the FVF not in (0, 1), or c1_f + c2_f not positive.

    Examples
    --------
    >>> from indentation_studio.design import rule_of_mixtures
    >>> rule_of_mixtures(20.0, 1000.0, 0.0, 0.3)
    (10.0, 307.0)
    """
    if not (np.isfinite(mu_matrix) and mu_matrix > 0):
        raise ValueError(f"the matrix shear modulus must be a positive number (kPa), got {mu_matrix!r}")
    if not (np.isfinite(fiber_volume_fraction) and 0 < fiber_volume_fraction < 1):
        raise ValueError(f"the fiber volume fraction must lie in (0, 1), got {fiber_volume_fraction!r}")
    if not (np.isfinite(c1_fiber) and np.isfinite(c2_fiber)) or c1_fiber + c2_fiber <= 0:
        raise ValueError(
            f"the fibers' initial stiffness c1_f + c2_f must be positive, got {c1_fiber!r} + {c2_fiber!r}"
        )
    c1 = mu_matrix / 2.0
    c5 = fiber_volume_fraction * (c1_fiber + c2_fiber) + (1.0 - fiber_volume_fraction) * c1
    return float(c1), float(c5)


def parallel_fiber_stresses(
    stretch, mu_matrix: float, c1_fiber: float, c2_fiber: float, fiber_volume_fraction: float
) -> tuple[np.ndarray, np.ndarray]:
    """Equibiaxial Cauchy stresses of continuous parallel fibers in a matrix, by a rule of mixtures.

    The constituents' own stresses are mixed by volume (Voigt along the fibers), incompressible,
    kPa.

    Along the fibers (direction 1) the fibers and the matrix share the stretch: the matrix is in
    equibiaxial tension, 2 c1_m (lam^2 - lam^-4) with c1_m = mu_m / 2 (the left side of eq. 10b),
    while a thin fiber is free to contract across its axis (the soft matrix hardly holds it), so it
    is in uniaxial tension, 2 (c1_f + c2_f / lam)(lam^2 - 1 / lam); sigma11 is their mix by volume.
    Across the fibers sigma22 is the matrix's.

    At small strain this gives sigma11 - sigma22 = FVF (6 (c1_f + c2_f) - 12 c1_m) (lam - 1): the
    c5 of eq. 10a is the fibers' Young's modulus 3 mu_f = 6 (c1_f + c2_f) times FVF, where eq. 11b
    takes FVF (c1_f + c2_f), six times less.

    Parameters
    ----------
    stretch : array_like
        Equibiaxial stretches lam (positive).
    mu_matrix : float
        Shear modulus of the matrix, kPa.
    c1_fiber, c2_fiber : float
        Mooney-Rivlin constants of the fibers, kPa.
    fiber_volume_fraction : float
        FVF.

    Returns
    -------
    sigma11 : numpy.ndarray
        Stress along the fibers, kPa.
    sigma22 : numpy.ndarray
        Stress across the fibers (the matrix's), kPa.

    Raises
    ------
    ValueError
        If a stretch is not a positive finite number.
    """
    lam = np.asarray(stretch, dtype=float)
    if np.any(~np.isfinite(lam)) or np.any(lam <= 0):
        raise ValueError("stretches must be positive finite numbers")
    matrix = mu_matrix * (lam**2 - lam**-4.0)
    fiber = 2.0 * (c1_fiber + c2_fiber / lam) * (lam**2 - 1.0 / lam)
    s11 = fiber_volume_fraction * fiber + (1.0 - fiber_volume_fraction) * matrix
    return s11, matrix


def _clean(stretch, *stresses) -> tuple[np.ndarray, ...]:
    lam = np.asarray(stretch, dtype=float).ravel()
    out = [np.asarray(s, dtype=float).ravel() for s in stresses]
    if any(s.shape != lam.shape for s in out):
        raise ValueError("stretch and stress must have the same number of points")
    if lam.size < 2:
        raise ValueError("a fit needs at least two stress-stretch points")
    if not (np.all(np.isfinite(lam)) and all(np.all(np.isfinite(s)) for s in out)):
        raise ValueError("the stress-stretch data hold NaN or infinite values")
    if np.any(lam <= 0):
        raise ValueError("stretches must be positive (lambda = current / reference length)")
    return lam, *out


def _to_cauchy(lam: np.ndarray, stress: np.ndarray, nominal: bool) -> np.ndarray:
    """Uniaxial, incompressible: sigma = lam P (P force over reference area)."""
    return lam * stress if nominal else stress


def _fit(model, x, y, names: tuple[str, ...], p0) -> Fit:
    popt, pcov = curve_fit(model, x, y, p0=p0)
    resid = y - model(x, *popt)
    err = (
        np.sqrt(np.clip(np.diag(pcov), 0.0, None))
        if np.all(np.isfinite(pcov))
        else np.full(len(popt), np.inf)
    )
    return Fit(
        dict(zip(names, map(float, popt), strict=True)),
        dict(zip(names, map(float, err), strict=True)),
        float(np.sqrt(np.mean(resid**2))),
        len(y),
    )


def fit_neo_hookean_uniaxial(stretch, stress, nominal: bool = False) -> Fit:
    """Incompressible neo-Hookean, sigma = mu (lam^2 - 1 / lam): the matrix's ``mu`` (S3)."""
    lam, s = _clean(stretch, stress)
    return _fit(lambda x, mu: mu * (x**2 - 1.0 / x), lam, _to_cauchy(lam, s, nominal), ("mu",), (1.0,))


def fit_mooney_rivlin_uniaxial(stretch, stress, nominal: bool = False) -> Fit:
    """Incompressible Mooney-Rivlin, sigma = 2 (c1 + c2 / lam)(lam^2 - 1 / lam): the fibers' (c1, c2) (S3)."""
    lam, s = _clean(stretch, stress)
    return _fit(
        lambda x, c1, c2: 2.0 * (c1 + c2 / x) * (x**2 - 1.0 / x),
        lam,
        _to_cauchy(lam, s, nominal),
        ("c1", "c2"),
        (1.0, 1.0),
    )


def fit_equibiaxial(stretch, sigma_fiber, sigma_transverse) -> Fit:
    """Fit (c1, c5) of eq. 2 to equibiaxial Cauchy stresses along and across the fibers (eq. 10a, 10b).

    Both curves are fitted at once (least squares).

    Parameters
    ----------
    stretch : array_like
        Equibiaxial stretches.
    sigma_fiber : array_like
        Cauchy stress along the fibers at each stretch, kPa (eq. 10a).
    sigma_transverse : array_like
        Cauchy stress across the fibers, kPa (eq. 10b).

    Returns
    -------
    Fit
        ``values`` and ``std_errors`` of c1 and c5 (kPa), ``rms_kPa`` and ``n_points``.
    """
    lam, s11, s22 = _clean(stretch, sigma_fiber, sigma_transverse)
    n = lam.size

    def model(x, c1, c5):
        a, b = equibiaxial_stress_incompressible(x[:n], c1, c5)
        return np.concatenate([a, b])

    return _fit(model, np.concatenate([lam, lam]), np.concatenate([s11, s22]), ("c1", "c5"), (1.0, 10.0))


@dataclass(frozen=True)
class Baseline:
    """theta* from the constituents (eq. 11) and, if equibiaxial data were given, their eq. 10 fit.

    Attributes
    ----------
    c1, c5 : float
        theta* by the rule of mixtures (eq. 11a, 11b), kPa.
    fiber_volume_fraction : float
        The FVF used.
    equibiaxial_fit : Fit or None
        The eq. 10 fit of the equibiaxial data, if any.
    """

    c1: float
    c5: float
    fiber_volume_fraction: float
    equibiaxial_fit: Fit | None = None

    def to_dict(self) -> dict[str, Any]:
        """The baseline as ``design baseline --json`` prints it.

        Returns
        -------
        dict
            c1, c5 (kPa), the source, and the eq. 10 fit's values, standard errors and RMS.
        """
        payload: dict[str, Any] = {"c1": self.c1, "c5": self.c5, "source": "eq. 11 (rule of mixtures)"}
        fit = self.equibiaxial_fit
        if fit is not None:
            payload["equibiaxial_fit"] = {
                "values": fit.values,
                "std_errors": fit.std_errors,
                "rms_kPa": fit.rms_kPa,
            }
        return payload


def baseline_from_constituents(
    mu_matrix: float,
    c1_fiber: float,
    c2_fiber: float,
    fiber_volume_fraction: float,
    *,
    equibiaxial: str | Path | None = None,
) -> Baseline:
    """The baseline theta* of eq. 11 and, with a CSV of equibiaxial data, the eq. 10 fit of it.

    Parameters
    ----------
    mu_matrix, c1_fiber, c2_fiber, fiber_volume_fraction
        As :func:`rule_of_mixtures`.
    equibiaxial : str or Path, optional
        A CSV with columns stretch, sigma_fiber and sigma_transverse (kPa).

    Returns
    -------
    Baseline
        (c1, c5) of eq. 11 and the fit.

    Raises
    ------
    ValueError
        A constituent out of range, or a column missing from the CSV.
    """
    c1, c5 = rule_of_mixtures(mu_matrix, c1_fiber, c2_fiber, fiber_volume_fraction)
    fit = None
    if equibiaxial is not None:
        table = pd.read_csv(equibiaxial)
        missing = {"stretch", "sigma_fiber", "sigma_transverse"} - set(table.columns)
        if missing:
            raise ValueError(f"{equibiaxial}: missing column(s) {', '.join(sorted(missing))}")
        fit = fit_equibiaxial(table["stretch"], table["sigma_fiber"], table["sigma_transverse"])
    return Baseline(c1, c5, fiber_volume_fraction, fit)
