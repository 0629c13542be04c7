"""Where the stage stood still in a load-frame record, at any sampling rate (1 Hz .. 1 kHz), and
where the indenter met the specimen.

A load frame records at 1 to 1,000 Hz; a step's ramp lasts 0.5 to 2 s. A reading belongs to a
hold only when the stage stands still: the hold of a run of readings is its longest stretch whose
depth stays within a *band* of the run's median depth, the band being a few times the position's
own noise (robust spread of the reading-to-reading differences) and at least
``MIN_BAND_STEPS`` of a step. A ramp's readings move through the band in a fraction of the band
over the stage's speed, so at most the last one or two readings of a ramp (a few milliseconds
before the stage stops) can fall into it, never a ramp's worth of them, whatever the rate.

The contact point (zero depth) is where the force leaves its unloaded baseline: the first
reading from which the force stays beyond ``ONSET_SIGMAS`` times its noise (and 0.1 % of its
largest excursion: a quantised reading) for ``ONSET_PERSIST_S`` (a single spike does not
count), walked back to where it first left ``ONSET_BACK_SIGMAS`` times the noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: the band of a hold: this many standard deviations of the position noise ...
BAND_SIGMAS = 6.0
#: ... and at least this fraction of the step size (an encoder without noise)
MIN_BAND_STEPS = 2e-3
#: the force's onset: beyond this many noise standard deviations of the baseline ...
ONSET_SIGMAS = 8.0
#: ... for this long (s; and at least 3 readings), walked back to this many
ONSET_PERSIST_S = 0.2
ONSET_BACK_SIGMAS = 2.0


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
    """The standard deviation of the noise of a signal that mostly stays put: 1.4826 MAD of the
    reading-to-reading differences over sqrt(2)."""
    d = np.diff(np.asarray(x, float))
    if not d.size:
        return 0.0
    return float(1.4826 * np.median(np.abs(d - np.median(d))) / np.sqrt(2.0))


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


def force_onset(f: np.ndarray, t: np.ndarray) -> int | None:
    """The index of the last unloaded reading before the force leaves its baseline (module
    docstring), or None when it never does. The baseline is a straight line through the first
    readings (the first 2 % of the record, at least 5): a drifting load cell's zero."""
    f, t = np.asarray(f, float), np.asarray(t, float)
    n = len(f)
    head = slice(0, max(5, n // 50))
    slope, offset = np.polyfit(t[head] - t[0], f[head], 1) if n >= 5 else (0.0, float(np.median(f)))
    dev = np.abs(f - (offset + slope * (t - t[0])))  # from the baseline (and its drift) of the start
    scale = float(dev.max()) if n else 0.0
    if scale == 0.0:
        return None
    sigma = robust_noise(f - slope * t)
    threshold = max(ONSET_SIGMAS * sigma, 1e-3 * scale)  # 0.1 % of the largest: a quantised reading
    above = dev > threshold
    dt = float(np.median(np.diff(t))) if n > 1 else 1.0
    persist = max(3, int(np.ceil(ONSET_PERSIST_S / dt)))
    # the first reading from which `persist` readings in a row are above
    count = np.convolve(above.astype(np.int64), np.ones(persist, np.int64), "valid")
    hits = np.flatnonzero(count == persist)
    if not hits.size:
        return None
    i = int(hits[0])
    back = max(ONSET_BACK_SIGMAS * sigma, 1e-9 * scale)
    while i > 0 and dev[i - 1] > back:
        i -= 1
    return max(i - 1, 0)


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
    return ", ".join(f"{s.depth_mm:.4g} mm for {s.duration_s:.3g} s" for s in keep) + more
