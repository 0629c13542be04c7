"""Plausibility of each hold's force readings, so that one bad hold of a real record (a load-cell
spike, a slipped step) is named by its step and row instead of condemning the whole file's unit.

* Units: each step's median force gives a Hertz-implied shear modulus F / (16/3 sqrt(R) d^1.5);
  when the median over the steps lies outside 0.1 kPa .. 100 MPa the forces cannot be
  millinewtons (the whole column's unit is wrong).
* One step whose modulus differs from the others' median by more than ``STEP_RATIO`` (x or /)
  is named with its rows (the steps 1 and 2 may fall short: contact is not exact).
* A spike: a reading farther from the hold's eq. 9 fit than ``SPIKE_SIGMAS`` robust standard
  deviations and than ``SPIKE_FRACTION`` of the hold's force is named by its step and row.

Each message says how to go on: fix the rows or leave the step out (``excluded_steps``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from .errors import ExperimentDataError
from .relaxation import relaxation_fit

STEP_RATIO = 20.0
SPIKE_SIGMAS = 8.0
SPIKE_FRACTION = 0.2
_LEAVE_OUT = "fix those rows or leave the step out of the fit (experiment.json: excluded_steps)"


def hertz_modulus(force_mN: np.ndarray, depth_mm: np.ndarray, radius: float) -> np.ndarray:
    """The shear modulus (kPa) a Hertz contact would need for ``force`` at ``depth``:
    F = 16/3 mu sqrt(R) d^1.5 (incompressible half-space, rigid sphere)."""
    return np.abs(force_mN) / (16.0 / 3.0 * np.sqrt(radius) * np.asarray(depth_mm, float) ** 1.5)


def _spike(t: np.ndarray, f: np.ndarray) -> tuple[int, float] | None:
    """The index and size of the worst reading that stands out of the hold's eq. 9 fit, if any."""
    try:
        fit = relaxation_fit(t, f)
    except ExperimentDataError:
        return None
    r = f - (fit.amplitude * np.exp(-fit.rate * (t - t.min())) + fit.f_inf)
    sigma = 1.4826 * np.median(np.abs(r - np.median(r)))
    i = int(np.argmax(np.abs(r)))
    if abs(r[i]) > SPIKE_SIGMAS * sigma and abs(r[i]) > SPIKE_FRACTION * abs(np.median(f)):
        return i, float(r[i])
    return None


def check_hold_forces(
    force: pd.DataFrame,
    radius: float,
    step_size: float,
    where: str,
    rows: np.ndarray | None = None,
    force_column: str = "force_mN",
    excluded_steps: Sequence[int] = (),
) -> None:
    """Raise :class:`ExperimentDataError` naming the file, step and rows of the first implausible
    hold of ``force`` (columns step, time_s, force_mN); ``rows`` are the file rows of its lines
    (default: index + 2, a CSV read whole)."""
    rows = force.index.to_numpy() + 2 if rows is None else np.asarray(rows)
    step = force["step"].to_numpy().astype(int)
    keep = ~np.isin(step, list(excluded_steps))
    steps = np.unique(step[keep])
    if not steps.size:
        return
    median_f = np.array([np.median(force["force_mN"].to_numpy()[keep & (step == k)]) for k in steps])
    mu = hertz_modulus(median_f, steps * step_size, radius)
    mu_all = float(np.median(mu))
    if not 0.1 <= mu_all <= 1e5:
        raise ExperimentDataError(
            f"{where}: column '{force_column}': these forces imply a shear modulus of {mu_all:.3g} kPa (Hertz, "
            "median over the steps), outside 0.1 kPa .. 100 MPa; they cannot be millinewtons (newtons, or micronewtons?)"
        )
    for k, m in zip(steps, mu, strict=True):
        ratio = m / mu_all
        if ratio > STEP_RATIO or (ratio < 1.0 / STEP_RATIO and k > 2):
            r = rows[step == k]
            raise ExperimentDataError(
                f"{where}: step {k} (rows {r.min()}..{r.max()}), column '{force_column}': its forces imply "
                f"{m:.3g} kPa (Hertz) while the steps' median implies {mu_all:.3g} kPa: a load-cell spike or a "
                f"slipped step? {_LEAVE_OUT}"
            )
    for k in steps:
        sel = np.flatnonzero(step == k)
        t, f = force["time_s"].to_numpy(float)[sel], force["force_mN"].to_numpy(float)[sel]
        hit = _spike(t, f)
        if hit is not None:
            i, size = hit
            raise ExperimentDataError(
                f"{where}: step {k}, row {rows[sel[i]]}, column '{force_column}': reading {f[i]:.4g} mN lies "
                f"{size:+.3g} mN off the hold's relaxation fit (eq. 9; a load-cell spike?); {_LEAVE_OUT}"
            )
