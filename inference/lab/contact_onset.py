"""Where the indenter met the specimen in a load-frame record: the onset of a power law fitted to
the loading, as indentation software finds a contact point (Hertz: F = c + a (d - d0)^m for
d > d0, c below it, m near 1.5), not where the force clears the noise.

The points fitted are the record's own, whatever its rate and lead-in:

* every stretch where the stage stood still before the deepest one (the holds of the loading and
  a wait at the contact or in air), each as the median position and the median force of its last
  third (relaxed, as the holds' forces are compared across steps), up to ``MAX_PLATEAUS`` of them;
* the readings before the first hold taken while the stage was at least a quarter of a step
  short of the contact the protocol implies (one step before the first hold: unloaded, an
  approach through air), and those after the loading where the stage withdrew as far, as the
  medians of up to ``MAX_BINS`` bins in time; with readings after the loading, or before it
  spanning ``DRIFT_SPAN_S`` or more, the baseline may drift linearly in time (a load cell's drift);
* where the first ramp into the specimen has ``RAMP_READINGS`` loaded readings or more, a second
  fit to them (and the unloaded ones) with any exponent m in 1 .. 3: the loading right at the
  contact. The exponent trades with the onset, so Hertz's m = 1.5 is kept unless another fits the
  ramp better by a chi-square of ``EXPONENT_CHI2`` (the readings' own noise): with its exponent
  free, the onset of a loading that follows Hertz wanders with the noise (0.006 mm at 10 Hz).

The fit (:func:`scipy.optimize.curve_fit`, a Cauchy loss: a step that slipped counts little; m
Hertz's 1.5 on the holds) gives d0, the contact. A record
that starts loaded (at the contact with a preload, the lab's zero) puts d0 before its first
reading; its first reading is then the contact (the steps are counted from there).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import OptimizeWarning, curve_fit

from .hold_detection import Stretch, hold_band, robust_noise, still_stretches

#: the exponent of the fit to the holds (Hertz's, a sphere's; the first ramp's readings fit any in 1 .. 3)
HERTZ = (1.5 - 1e-6, 1.5 + 1e-6)
#: the stretches where the stage stood still that the fit uses (the loading's first holds)
MAX_PLATEAUS = 12
#: the unloaded readings before the first hold are binned into at most this many medians
MAX_BINS = 60
#: the first ramp's readings the onset is fitted to when it has this many (else to the holds')
RAMP_READINGS = 8
#: unloaded readings spanning this long (s) give the baseline's drift
DRIFT_SPAN_S = 30.0
#: the chi-square by which Hertz's exponent must fit the first ramp worse for another to be taken
EXPONENT_CHI2 = 9.0


@dataclass(frozen=True)
class ContactOnset:
    """The contact found from the force: ``position_mm`` (on the record's position axis), how
    (``source``), the fitted law (baseline ``baseline_mN`` at ``time_s`` drifting by
    ``drift_mN_per_s``, in the record's force units and sign; exponent ``power``), what the fit
    saw, and the force above the baseline where a record that starts loaded starts."""

    position_mm: float
    source: str
    baseline_mN: float
    drift_mN_per_s: float
    time_s: float
    power: float
    notes: list[str] = field(default_factory=list)
    #: the force above the baseline where the record starts (a preload; 0 within the noise)
    start_load_mN: float = 0.0


def _plateaus(t: np.ndarray, depth: np.ndarray, step_size: float) -> list[Stretch]:
    """The stretches where the stage stood still (:func:`.hold_detection.still_stretches` on
    levels a half step wide, centred on where the stage stood: two passes), lasting 1 s and
    4 readings, with their depths."""
    shift, long = 0.0, []
    for _ in range(2):
        found = still_stretches(t, depth - shift, step_size, 0.5)
        long = [
            Stretch(s.first, s.last, s.depth_mm + shift, s.start_s, s.end_s)
            for _, s in found
            if s.duration_s >= 1.0 and s.readings >= 4
        ]
        if not long:
            return []
        phase = np.angle(np.mean(np.exp(2j * np.pi * np.array([s.depth_mm for s in long]) / step_size)))
        shift = float(phase) / (2 * np.pi) * step_size
    return long


def _tail(s: Stretch) -> slice:
    """The last third of a stretch's readings (at least 2)."""
    n = s.readings
    return slice(s.last + 1 - max(2, n // 3), s.last + 1)


def _fit(x, y, t_ref, drifts, c0, span, d0_range, guesses, powers=(1.0, 3.0)) -> tuple[float, ...] | None:
    """(c, b, a, d0, m) of y = c + b (t - t_ref) + a (d - d0)_+^m fitted to ``x`` = (d, t) and
    ``y`` from each of the ``guesses`` of d0 (the best kept); b = 0 unless ``drifts``; m within
    ``powers``."""

    def law(x, c, b, a, d0, m):
        dd, ti = x
        return c + b * (ti - t_ref) + a * np.clip(dd - d0, 0.0, None) ** m

    top = max(float(np.max(y) - c0), 1e-9)
    lo = [-np.inf, -np.inf if drifts else -1e-6, 0.0, d0_range[0], powers[0]]
    hi = [np.inf, np.inf if drifts else 1e-6, np.inf, d0_range[1] - 1e-6, powers[1]]
    f_scale = 0.01 * top  # residuals beyond 1 % of the loading's force count less (a step that slipped)
    best, cost = None, np.inf
    for guess in guesses:
        p0 = np.clip([c0, 0.0, top / span**1.5, guess, 1.5], np.add(lo, 1e-9), np.subtract(hi, 1e-9))
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", OptimizeWarning)
                fit, _ = curve_fit(
                    law, x, y, p0=p0, bounds=(lo, hi), x_scale="jac", loss="cauchy", f_scale=f_scale
                )
        except (RuntimeError, ValueError):
            continue
        z = ((law(x, *fit) - y) / f_scale) ** 2
        r = float(np.sum(np.log1p(z)))  # the Cauchy loss minimised
        if r < cost:
            best, cost = tuple(float(v) for v in fit), r
    return best


def _law(x, c, b, a, d0, m, t_ref):
    """c + b (t - t_ref) + a (d - d0)_+^m at ``x`` = (d, t)."""
    dd, ti = x
    return c + b * (ti - t_ref) + a * np.clip(dd - d0, 0.0, None) ** m


def _exponent_needed(free, hertz, x, y, t_ref, counts, noise) -> tuple[float, ...] | None:
    """The fit with any exponent (``free``) where the readings need it, else Hertz's (``hertz``).

    The readings need it when Hertz's m = 1.5 leaves them ``EXPONENT_CHI2`` more chi-square than
    the best exponent, the medians of ``counts`` readings each weighted by the force ``noise``
    (a median of n readings varies as pi/2 sigma^2/n): a free exponent trades with the onset, so
    the onset of a loading that follows Hertz is read with his exponent, not moved by the noise.
    """
    if free is None or hertz is None or noise <= 0:
        return free if hertz is None else hertz if free is None else free
    var = noise**2 * np.where(counts > 2, 0.5 * np.pi / np.maximum(counts, 1), 1.0)
    chi2 = [float(np.sum((_law(x, *p, t_ref) - y) ** 2 / var)) for p in (free, hertz)]
    return free if chi2[1] - chi2[0] > EXPONENT_CHI2 else hertz


def power_law_onset(
    t: np.ndarray, position: np.ndarray, force: np.ndarray, step_size: float, sign: float
) -> ContactOnset | None:
    """The contact of a load-frame record (module docstring).

    Parameters
    ----------
    t : numpy.ndarray
        The readings' times, s.
    position : numpy.ndarray
        The stage's position, mm.
    force : numpy.ndarray
        The force, mN, either sign.
    step_size : float
        The protocol's depth per step, mm.
    sign : float
        +1 when the position grows into the specimen, -1 when it falls.

    Returns
    -------
    ContactOnset or None
        The contact and the law fitted; None when the record holds too little to fit (fewer
        than 3 stretches where the stage stood still, no ladder of holds one step apart).
    """
    t, position, force = (np.asarray(v, float) for v in (t, position, force))
    depth = sign * (position - position[0])  # from the first reading, growing into the specimen
    plateaus = _plateaus(t, depth, step_size)
    if len(plateaus) < 3:
        return None
    deepest = max(range(len(plateaus)), key=lambda i: plateaus[i].depth_mm)
    loading = plateaus[: deepest + 1]
    pd_ = np.array([float(np.median(depth[_tail(s)])) for s in loading])
    pf = np.array([float(np.median(force[_tail(s)])) for s in loading])
    pt = np.array([float(np.mean(t[_tail(s)])) for s in loading])
    # the ladder of holds: from the first stretch one step short of the next (a wait at the
    # contact is its first rung when the record has one: the fit tells it from a hold)
    rung = np.abs(np.diff(pd_) - step_size) <= 0.25 * step_size
    first = next((i for i in range(len(rung)) if rung[i]), None)
    if first is None:
        return None
    keep = slice(0, min(len(loading), first + MAX_PLATEAUS))
    pd_, pf, pt = pd_[keep], pf[keep], pt[keep]
    fsign = float(np.sign(pf[-1] - pf[0])) or 1.0
    y_p = fsign * pf
    # unloaded readings: before the ladder, a quarter step short of a step before its first rung
    # (an approach through air), and after the loading when the stage withdrew as far
    short = depth < pd_[first] - 1.25 * step_size
    air = np.flatnonzero((t < t[loading[first].first]) & short)
    withdrawn = np.flatnonzero((t > t[loading[-1].last]) & short)
    bins = np.array_split(air, min(MAX_BINS, len(air))) if air.size else []
    bins += np.array_split(withdrawn, min(MAX_BINS // 3, len(withdrawn))) if withdrawn.size else []
    ad = np.array([float(np.median(depth[k])) for k in bins])
    ay = np.array([fsign * float(np.median(force[k])) for k in bins])
    at = np.array([float(np.mean(t[k])) for k in bins])
    d, y, tt = np.concatenate([ad, pd_]), np.concatenate([ay, y_p]), np.concatenate([at, pt])
    t_ref = float(pt[first])
    # a drift when unloaded readings span long, or come after the loading (against a wait at the contact)
    drifts = withdrawn.size >= 2 or (air.size >= 2 and float(np.ptp(t[air])) >= DRIFT_SPAN_S)

    c0 = float(np.median(ay)) if air.size else float(y_p[: first + 1].min())
    span = max(float(pd_[-1] - pd_[first]) + step_size, step_size)
    guesses = (pd_[first] - step_size, pd_[first])  # a hold is the first rung, or a wait at the contact
    fit = _fit(
        (d, tt),
        y,
        t_ref,
        drifts,
        c0,
        span,
        (float(d.min()) - step_size, float(pd_[first + 1])),
        guesses,
        HERTZ,
    )
    if fit is None:
        return None
    c, b, _, d0, m = fit
    how = f"{len(pd_)} stretches where the stage stood still" + (
        f" and {len(bins)} unloaded readings' medians" if bins else ""
    )
    # where the first ramp into the specimen has readings enough, the onset is fitted to them
    # (and to the unloaded ones before): the loading right at the contact, as the holds' relaxed
    # forces on a finite specimen follow a power law only roughly
    loaded = [s for s in loading if s.depth_mm > d0 + 0.25 * step_size]
    if loaded:
        target = loaded[0]
        before = [s for s in loading if s.last < target.first]
        after = before[-1].last + 1 if before else 0  # the ramp starts where the stage last stood
        ramp = np.arange(after, target.first)
        ramp = ramp[(depth[ramp] > d0 - 0.5 * step_size) & (depth[ramp] < target.depth_mm)]
        if np.count_nonzero(depth[ramp] > d0 + 0.05 * step_size) >= RAMP_READINGS:  # loaded readings enough
            near = ramp[depth[ramp] >= d0 - 0.1 * step_size]  # the ramp's readings one by one, or in bins
            rb = np.array_split(near, min(MAX_BINS, near.size))
            rest = ramp[depth[ramp] < d0 - 0.1 * step_size]  # the approach's last readings, in 20 bins
            rb += np.array_split(rest, min(20, rest.size)) if rest.size else []
            d2 = [ad, [float(np.median(depth[k])) for k in rb]]
            y2 = [ay, [fsign * float(np.median(force[k])) for k in rb]]
            t2 = [at, [float(np.mean(t[k])) for k in rb]]
            n2 = [[len(k) for k in bins], [len(k) for k in rb]]
            if before and before[-1].depth_mm > d0 - 1.25 * step_size:  # a wait at (or near) the contact
                w = _tail(before[-1])
                d2.append([float(np.median(depth[w]))])
                y2.append([fsign * float(np.median(force[w]))])
                t2.append([float(np.mean(t[w]))])
                n2.append([w.stop - w.start])
            x2, y2 = (np.concatenate(d2), np.concatenate(t2)), np.concatenate(y2)
            args = (x2, y2, t_ref, drifts, c, float(target.depth_mm - d0))
            bounds = (d0 - 0.5 * step_size, float(target.depth_mm))
            free = _fit(*args, bounds, (d0,))
            hertz = _fit(*args, bounds, (d0,), HERTZ)
            fit2 = _exponent_needed(free, hertz, x2, y2, t_ref, np.concatenate(n2), robust_noise(force))
            if fit2 is not None:
                c, b, _, d0, m = fit2
                how = f"{len(rb)} medians of the first ramp's readings" + (
                    f" and {len(bins)} unloaded ones" if bins else ""
                )
    notes = [f"contact from a power law fitted to the loading (F = c + a (d - d0)^{m:.2f} over {how})"]
    band = hold_band(depth, step_size)
    if d0 < -band:  # before the first reading: the record starts at the contact (the lab's zero)
        loaded = fsign * float(np.median(force[_tail(loading[0])])) - c
        loaded = loaded if abs(loaded) > 5.0 * robust_noise(force) else 0.0  # a preload, or the noise
        notes.append(
            f"the power law's onset lies {-d0:.3g} mm before the record's first reading (which is "
            f"{loaded:.3g} mN above the fitted baseline): the record starts at the contact; depths from its first reading"
        )
        return ContactOnset(
            float(position[0]), "first reading", fsign * c, fsign * b, t_ref, m, notes, loaded
        )
    d0 = max(d0, 0.0)
    noise = robust_noise(force)
    if noise > 0:
        notes[0] += f"; force noise {noise:.2g} mN"
    return ContactOnset(float(position[0] + sign * d0), "force onset", fsign * c, fsign * b, t_ref, m, notes)
