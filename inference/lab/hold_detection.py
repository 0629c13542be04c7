"""Where the stage stood still in a load-frame record, at any sampling rate (1 Hz .. 1 kHz).

A load frame records at 1 to 1,000 Hz; a step's ramp lasts 0.5 to 2 s. A reading belongs to a
hold only when the stage stands still: the hold of a run of readings is its longest stretch whose
depth stays within a *band* of the run's median depth, the band being a few times the position's
own noise (robust spread of the second differences, which a hold and a ramp at constant speed,
however slow, leave at zero) and at least
``MIN_BAND_STEPS`` of a step. A ramp's readings move through the band in a fraction of the band
over the stage's speed, so at most the last one or two readings of a ramp (a few milliseconds
before the stage stops) can fall into it, never a ramp's worth of them, whatever the rate.

Where the indenter met the specimen is :mod:`.contact_onset`'s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: the band of a hold: this many standard deviations of the position noise ...
BAND_SIGMAS = 6.0
#: ... and at least this fraction of the step size (an encoder without noise)
MIN_BAND_STEPS = 2e-3


@dataclass(frozen=True)
class Stretch:
    """Readings ``first``..``last`` (0-based, inclusive) where the stage stood at ``depth_mm``."""

    first: int
    last: int
    depth_mm: float
    start_s: float
    end_s: float

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s

    @property
    def readings(self) -> int:
        return self.last - self.first + 1


def robust_noise(x: np.ndarray) -> float:
    """The standard deviation of the noise of a signal made of stretches that stand still or move
    at a constant speed (holds, ramps, a slow approach): 1.4826 MAD of its second differences
    over sqrt(6), which only the corners between stretches leave off zero."""
    d = np.diff(np.asarray(x, float), 2)
    if not d.size:
        return 0.0
    return float(1.4826 * np.median(np.abs(d - np.median(d))) / np.sqrt(6.0))


def hold_band(depth: np.ndarray, step_size: float) -> float:
    """The band (mm) within which the depth of a held stage stays (module docstring)."""
    return max(BAND_SIGMAS * robust_noise(depth), MIN_BAND_STEPS * step_size)


def runs(labels: np.ndarray) -> list[tuple[int, int, int]]:
    """(label, first, last) of each maximal run of equal labels."""
    labels = np.asarray(labels)
    if not labels.size:
        return []
    edges = np.flatnonzero(np.diff(labels) != 0)
    starts = np.concatenate([[0], edges + 1])
    ends = np.concatenate([edges, [len(labels) - 1]])
    return [(int(labels[a]), int(a), int(b)) for a, b in zip(starts, ends, strict=True)]


def longest_inside(t: np.ndarray, inside: np.ndarray) -> tuple[int, int] | None:
    """(first, last) of the longest-lasting run of True in ``inside``."""
    best, span = None, -1.0
    for v, a, b in runs(inside.astype(np.int64)):
        if v == 1 and t[b] - t[a] > span:
            best, span = (a, b), t[b] - t[a]
    return best


def still_stretches(
    t: np.ndarray, depth: np.ndarray, step_size: float, level_tol: float, min_s: float = 0.0
) -> list[tuple[int, Stretch]]:
    """Every stretch where the stage stood still, with the step level it sits at (k when within
    ``level_tol`` steps of k steps, else None as -1e9): each run of readings at one level (or off
    every level) trimmed to its held part (its longest stretch within the band of its median depth), kept when it lasts ``min_s``."""
    band = hold_band(depth, step_size)
    level = np.rint(depth / step_size)
    on_level = np.abs(depth - level * step_size) <= level_tol * step_size
    labels = np.where(on_level, level, OFF).astype(np.int64)
    out = []
    for k, a0, b0 in runs(labels):
        d = depth[a0 : b0 + 1]
        inside = np.abs(d - np.median(d)) <= band
        hit = longest_inside(t[a0 : b0 + 1], inside)
        if hit is None:
            continue
        a, b = _trim_ramps(t, depth, a0, a0 + hit[0], a0 + hit[1], b0, float(np.median(d)))
        s = Stretch(a, b, float(np.median(depth[a : b + 1])), float(t[a]), float(t[b]))
        if s.duration_s >= min_s:
            out.append((k, s))
    return out


OFF = -(10**9)  # the label of readings off every level


def _ramp_end(t: np.ndarray, d: np.ndarray, level: float) -> float | None:
    """When the straight line through a ramp's readings ``t``, ``d`` reaches ``level``."""
    if len(t) < 2 or np.ptp(t) == 0:
        return None
    slope, offset = np.polyfit(t - t[0], d, 1)
    if slope == 0:
        return None
    return float(t[0] + (level - offset) / slope)


def _trim_ramps(t, depth, a0: int, a: int, b: int, b0: int, level: float) -> tuple[int, int]:
    """The stretch ``a``..``b`` less the ramp readings that fall inside its band: the readings
    of the run ``a0``..``b0`` before (after) it are the ramp approaching (leaving) the level; the
    line through the last (first) 50 of them says when the stage stopped (started), and readings
    before (after) that go."""
    if a - a0 >= 2:
        lead = slice(max(a0, a - 50), a)
        stop = _ramp_end(t[lead], depth[lead], level)
        if stop is not None and stop <= t[b]:
            while a < b and t[a] < stop - 1e-9 * max(1.0, abs(stop)):
                a += 1
    if b0 - b >= 2:
        tail = slice(b + 1, min(b0 + 1, b + 51))
        go = _ramp_end(t[tail], depth[tail], level)
        if go is not None and go >= t[a]:
            while b > a and t[b] > go + 1e-9 * max(1.0, abs(go)):
                b -= 1
    return a, b


def describe_stretches(stretches: list[tuple[int, Stretch]], limit: int = 12) -> str:
    """'0.5 mm for 30 s, 1 mm for 30 s, ...' of the stretches (longest first when cut)."""
    items = [s for _, s in stretches]
    if not items:
        return "none"
    if len(items) > limit:
        keep = sorted(sorted(items, key=lambda s: -s.duration_s)[:limit], key=lambda s: s.first)
        more = f" and {len(items) - limit} more"
    else:
        keep, more = items, ""
    return ", ".join(f"{round(s.depth_mm, 6) + 0.0:.4g} mm for {s.duration_s:.3g} s" for s in keep) + more
