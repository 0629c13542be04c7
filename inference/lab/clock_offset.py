"""The offset between the DIC cameras' clock and the load frame's, found from the data.

Each DIC frame's indentation signal (how far the points that moved most out of the reference
surface's plane moved: the surface next to the indenter, which sinks with the depth) is
matched to the stage's depth on the load frame's clock. The first frame that shows an indentation
was taken during step 1 (its ramp or hold) and the frame before it before the stage moved: that
bounds the offset (the first indented frame against the first hold). Within those bounds, the
offset (added to the frame times)
minimises the misfit of ``signal = a * depth(t + offset)^p`` (``a``, ``p`` fitted) over a
grid of offsets, among those that put as many frames as can be inside the holds (a DIC frame
of a stepwise test is taken while the stage stands). Frames taken during holds fit equally well
over a range of offsets (the holds' flat depth); the range is reported. The offset is never
guessed: it is 0 when the range holds 0 (the clocks agree as far as the data can tell); else,
when the range spans more than ``MAX_RANGE_FRACTION`` of the time between frames, the data do
not decide it and the offset must be given (an error with the range and ``--time-offset``);
else it is the range's middle.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..experiment.data import ExperimentDataError
from ..experiment.specimen_frame import surface_plane
from .dic_series import DICSeries


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
        why = " (0: the clocks agree as far as the data tell)" if self.offset_s == 0 else ""
        return (
            f"DIC clock offset {self.offset_s:.4g} s found from the data{why} (offsets {self.low_s:.4g} .. "
            f"{self.high_s:.4g} s fit as well; misfit {self.misfit_mm:.3g} mm RMS of the frames' indentation)"
        )


def indentation_signal(dic: DICSeries, fraction: float = 0.02) -> np.ndarray:
    """Per frame: how far the points that moved most out of the reference surface's plane moved,
    relative to the frame's median: the larger in size of the means of its ``fraction`` highest
    and lowest out-of-plane displacements (mm; the surface beside the indenter sinks, noise
    moves points both ways). The plane is that of the reference positions, so camera
    coordinates do as well as the specimen's."""
    _, normal = surface_plane(dic.xyz)
    out = np.full(len(dic.frame_ids), np.nan)
    for i, u in enumerate(dic.u):
        ok = np.isfinite(u).all(axis=1)
        if ok.sum() < 50:
            continue
        w = np.sort(u[ok] @ normal - np.median(u[ok] @ normal))
        k = max(int(fraction * len(w)), 3)
        out[i] = max(abs(float(w[:k].mean())), abs(float(w[-k:].mean())))
    return out


#: the widest range of offsets that fit as well, as a fraction of the median time between frames,
#: within which the data decide the offset (wider: the offset must be given, unless 0 is in it)
MAX_RANGE_FRACTION = 0.1

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


def _first_indentation_window(ft, sig, t, d, first_hold_end_s) -> tuple[float, float] | None:
    """The offsets that put the first indented frame (its signal above twice the least frame's,
    which sees only noise) after the stage left the contact point and by the end of step 1's
    hold, and the frame before it before the stage left: None when no frame is clearly flat."""
    base = float(sig.min())
    indented = np.flatnonzero(sig > 2.0 * base + 1e-12)
    if base <= 0 or not indented.size or indented[0] == 0:
        return None
    f = int(indented[0])
    moved = np.flatnonzero(d > 1e-3 * float(d.max()))  # beyond the contact found (to its precision)
    if not moved.size:
        return None
    leave = float(t[moved[0] - 1] if moved[0] > 0 else t[0])
    end = first_hold_end_s if first_hold_end_s is not None else float(t[-1])
    lo, hi = leave - ft[f], min(end - ft[f], leave - ft[f - 1])
    return (lo, hi) if hi > lo else None


def find_clock_offset(
    frame_times: np.ndarray,
    signal: np.ndarray,
    record_t: np.ndarray,
    record_depth: np.ndarray,
    hold_windows: np.ndarray | None = None,
    max_range_fraction: float | None = MAX_RANGE_FRACTION,
) -> ClockOffset:
    """The offset (module docstring) from the frames' times and indentation signals, the
    record's depth track and its holds' (start, end) times.

    Parameters
    ----------
    frame_times : numpy.ndarray
        The DIC frames' times on their own clock, s.
    signal : numpy.ndarray
        Each frame's indentation signal (:func:`indentation_signal`), mm.
    record_t, record_depth : numpy.ndarray
        The load frame's times (s) and the stage's depth from the contact (mm).
    hold_windows : numpy.ndarray, optional
        (steps, 2) start and end of each hold on the record's clock, s.
    max_range_fraction : float or None, default MAX_RANGE_FRACTION
        The widest range of offsets that fit as well, as a fraction of the time between frames,
        taken as decided by the data (None: any, its middle taken).

    Returns
    -------
    ClockOffset
        The offset, the range that fits as well, the misfit and the fitted law.

    Raises
    ------
    ExperimentDataError
        Too few frames show the indentation, or the range is wider than ``max_range_fraction``
        of the time between frames and does not hold 0 (the message gives the range and the
        option, ``--time-offset``).
    """
    ok = np.isfinite(signal) & np.isfinite(frame_times)
    ft, sig = np.asarray(frame_times, float)[ok], np.asarray(signal, float)[ok]
    if len(ft) < 3 or np.ptp(sig) == 0:
        raise ExperimentDataError(
            "the clocks' offset cannot be found from the data: too few DIC frames show the indentation; "
            "give it (--time-offset)"
        )
    t, d = np.asarray(record_t, float), np.clip(np.asarray(record_depth, float), 0.0, None)
    windows = None if hold_windows is None else np.asarray(hold_windows, float)
    if windows is not None:
        windows = windows[np.isfinite(windows).all(axis=1)]
    lo, hi = t[0] - ft.max(), t[-1] - ft.min()
    first = _first_indentation_window(
        ft, sig, t, d, None if windows is None or not len(windows) else windows[0, 1]
    )
    if first is not None:
        lo, hi = max(lo, first[0]), min(hi, first[1])
    dt = float(np.median(np.diff(t)))
    step = max((hi - lo) / 20000.0, dt / 2.0)
    grid = np.arange(lo, hi + step, step)
    if windows is not None and len(windows):
        at = ft[None, :] + grid[:, None]  # (offsets, frames)
        inside = ((at[..., None] >= windows[:, 0]) & (at[..., None] <= windows[:, 1])).any(axis=2).sum(axis=1)
        grid = grid[inside == inside.max()]  # as many frames in holds as can be
    cost = np.concatenate(
        [
            _misfit(sig, np.interp(ft[None, :] + g[:, None], t, d))[0]
            for g in np.array_split(grid, 1 + len(grid) // 2000)
        ]
    )
    best = float(cost.min())
    tie = cost <= best * 1.02 + 1e-9 * float(np.ptp(sig))  # 2 %: the record's position noise
    i = int(np.argmin(cost))
    a = i
    while a > 0 and tie[a - 1] and grid[a] - grid[a - 1] <= 1.5 * step:
        a -= 1
    b = i
    while b < len(grid) - 1 and tie[b + 1] and grid[b + 1] - grid[b] <= 1.5 * step:
        b += 1
    low, high = float(grid[a]), float(grid[b])
    interval = float(np.median(np.diff(np.sort(ft))))
    if low <= 0.0 <= high:
        offset = 0.0
    elif max_range_fraction is not None and high - low > max_range_fraction * interval:
        raise ExperimentDataError(
            f"the clocks' offset is not decided by the data: offsets {low:.4g} .. {high:.4g} s (added to the DIC "
            f"frame times) fit as well, {high - low:.3g} s of the {interval:.3g} s between frames (more than "
            f"{max_range_fraction:.0%}; the frames were taken while the stage stood, where any of them fits); "
            "give it: --time-offset SECONDS (from the lab's notes: the time on the load frame's clock when the "
            "cameras' clock read 0)"
        )
    else:
        offset = 0.5 * (low + high)
    misfit, scale, power = (float(v[0]) for v in _misfit(sig, np.interp(ft + offset, t, d)))
    return ClockOffset(offset, low, high, misfit, scale, power)
