"""The offset between the DIC cameras' clock and the load frame's, found from the data.

Each DIC frame's indentation signal (the 99th percentile of its points' displacement from the
frame's median displacement: the surface next to the indenter, which moves with the depth) is
matched to the stage's depth on the load frame's clock: the offset (added to the frame times)
minimises the misfit of ``signal = a * depth(t + offset)^p`` (``a``, ``p`` fitted) over a
grid of offsets. Frames taken during holds fit equally well over a range of offsets (the holds'
flat depth; misfits within 1/sqrt(frames) of the least count as equal: the frames' own scatter
about the relation, 0.97 u mid-hold against u at its end, can favour a wrong offset by a few
percent); the range is reported, and the offset chosen is 0 when the range holds
it (the clocks agree as far as the data can tell), else its middle.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from .dic_series import DICSeries
from .experiment_data import ExperimentDataError


@dataclass(frozen=True)
class ClockOffset:
    """``offset_s`` added to the DIC frame times reaches the load frame's clock; ``low_s`` ..
    ``high_s`` fit as well; ``misfit_mm`` the RMS of signal - a depth at the offset."""

    offset_s: float
    low_s: float
    high_s: float
    misfit_mm: float
    scale: float
    power: float = 1.0
    source: str = "data"

    def to_dict(self) -> dict:
        return asdict(self)

    def describe(self) -> str:
        if self.source == "given":
            return f"DIC clock offset {self.offset_s:g} s (given)"
        return (
            f"DIC clock offset {self.offset_s:.4g} s found from the data (offsets {self.low_s:.4g} .. "
            f"{self.high_s:.4g} s fit as well; misfit {self.misfit_mm:.3g} mm RMS of the frames' indentation)"
        )


def indentation_signal(dic: DICSeries) -> np.ndarray:
    """Per frame: the 99th percentile of |u - median(u)| over its correlated points (mm)."""
    out = np.zeros(len(dic.frame_ids))
    for i, u in enumerate(dic.u):
        ok = np.isfinite(u).all(axis=1)
        if ok.sum() < 10:
            out[i] = np.nan
            continue
        v = u[ok] - np.median(u[ok], axis=0)
        out[i] = float(np.percentile(np.linalg.norm(v, axis=1), 99))
    return out


#: exponents tried in signal = a depth^p (the surface beside the indenter moves less than the
#: indenter at first: its shadow, the contact circle, grows with the depth)
EXPONENTS = np.linspace(0.5, 3.0, 26)


def _misfit(signal: np.ndarray, depth: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per row of ``depth`` (offsets, frames): the least RMS of signal - a depth^p over a and
    the ``EXPONENTS``, and that a and p."""
    depth = np.atleast_2d(depth)
    best = np.full(len(depth), np.inf)
    best_a, best_p = np.zeros(len(depth)), np.ones(len(depth))
    for p in EXPONENTS:
        dp = depth**p
        dd = np.einsum("of,of->o", dp, dp)
        a = np.where(dd > 0, dp @ signal / np.where(dd > 0, dd, 1.0), 0.0)
        r = np.sqrt(np.mean((signal - a[:, None] * dp) ** 2, axis=1))
        better = r < best
        best[better], best_a[better], best_p[better] = r[better], a[better], p
    return best, best_a, best_p


def find_clock_offset(
    frame_times: np.ndarray, signal: np.ndarray, record_t: np.ndarray, record_depth: np.ndarray
) -> ClockOffset:
    """The offset (module docstring) from the frames' times and indentation signals and the
    record's depth track."""
    ok = np.isfinite(signal) & np.isfinite(frame_times)
    ft, sig = np.asarray(frame_times, float)[ok], np.asarray(signal, float)[ok]
    if len(ft) < 3 or np.ptp(sig) == 0:
        raise ExperimentDataError(
            "the clocks' offset cannot be found from the data: too few DIC frames show the indentation; "
            "give it (--time-offset)"
        )
    t, d = np.asarray(record_t, float), np.clip(np.asarray(record_depth, float), 0.0, None)
    lo, hi = t[0] - ft.max(), t[-1] - ft.min()
    dt = float(np.median(np.diff(t)))
    step = max((hi - lo) / 20000.0, dt / 2.0)
    grid = np.arange(lo, hi + step, step)
    cost = np.concatenate(
        [
            _misfit(sig, np.interp(ft[None, :] + g[:, None], t, d))[0]
            for g in np.array_split(grid, 1 + len(grid) // 2000)
        ]
    )
    best = float(cost.min())
    tie = cost <= best * (1.0 + 1.0 / np.sqrt(len(sig))) + 1e-6 * float(np.ptp(sig))
    i = int(np.argmin(cost))
    a = i
    while a > 0 and tie[a - 1]:
        a -= 1
    b = i
    while b < len(grid) - 1 and tie[b + 1]:
        b += 1
    low, high = float(grid[a]), float(grid[b])
    offset = 0.0 if low <= 0.0 <= high else 0.5 * (low + high)
    misfit, scale, power = (float(v[0]) for v in _misfit(sig, np.interp(ft + offset, t, d)))
    return ClockOffset(offset, low, high, misfit, scale, power)
