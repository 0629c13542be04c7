"""Contact detection on a table of synthetic load-frame records (issue 47): 4 lead-ins x 3 rates x 2
protocol lengths, each cut into holds by :func:`inference.lab.load_frame.find_holds` with the
protocol's options alone, with the depth error of every hold and the number of holds found.

    .venv/bin/python docs/figures/guide_import_and_check_detection.py [--rates 1,10,100] [--steps 10,40]

The records (:func:`synthetic_record`): steps of 0.5 mm (2 s ramps, 30 s holds in which the force
relaxes by eq. 9 to Hertz's F = 16/3 mu sqrt(R) d^1.5, mu = 4 kPa, R = 4.77 mm, by 30 % with a
4 s time constant), 0.5 % force noise (of step 1's force), a load cell drifting 0.005 mN/s, and
the withdrawal to 1 mm above the contact. The lead-ins:

* ``preload``: the record starts with the indenter pressed in to a 12 mN preload (0.40 mm past the
  first touch, by Hertz), the lab's zero: the steps are counted from there, as a test machine
  does after its preload; the true contact of the protocol is that first position;
* ``contact``: the record starts at the contact, unloaded, 10 s before step 1;
* ``air-10s``, ``air-300s``: the stage approaches the specimen through air for 10 s (from 2 mm
  above) or 300 s (from 3 mm above), and goes on into step 1 without stopping at the contact.

The depth error of a hold is its depth from the contact found less its depth from the true
contact (mm); the target is at most 0.01 mm.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd

from indentation_studio.inference.experiment.data import ExperimentDataError
from indentation_studio.inference.lab.load_frame import LoadFrameRecord, find_holds

LEAD_INS = ("preload", "contact", "air-10s", "air-300s")
STEP_SIZE, RADIUS, MU_KPA = 0.5, 4.77, 4.0
POSITION0 = 37.5  # the stage's position at the contact (it falls into the specimen)


def hertz(depth: np.ndarray) -> np.ndarray:
    """Hertz's force (mN) of the sphere at ``depth`` (mm) on a half-space of shear modulus mu."""
    return 16.0 / 3.0 * MU_KPA * np.sqrt(RADIUS) * np.clip(depth, 0.0, None) ** 1.5


def synthetic_record(
    lead_in: str,
    rate_hz: float,
    steps: int,
    *,
    ramp_s: float = 2.0,
    hold_s: float = 30.0,
    relax: float = 0.3,
    tau_s: float = 4.0,
    noise: float = 0.005,
    drift_mN_per_s: float = 0.005,
    preload_mN: float = 12.0,
    seed: int = 0,
) -> tuple[pd.DataFrame, float]:
    """A record (``Time [s]``, ``Position [mm]``, ``Force [N]`` negative in compression) with
    ``lead_in`` (module docstring), and the position of its true contact (mm)."""
    rng = np.random.default_rng(seed)
    pieces: list[tuple[float, object, object]] = []  # (duration, depth(s), force(s)); depth from contact
    pressed = 0.0  # depth past the first touch at the protocol's zero (the preload's)
    if lead_in == "preload":
        pressed = (preload_mN / float(hertz(np.array(1.0)))) ** (2.0 / 3.0)

    def touch(d):  # the force at depth d from the protocol's zero
        return hertz(np.asarray(d) + pressed)

    if lead_in in ("preload", "contact"):
        pieces.append((10.0, lambda s: 0.0 * s, lambda s: touch(0.0 * s)))
    elif lead_in.startswith("air-"):
        approach_s = float(lead_in[4:-1])
        height = 2.0 if approach_s <= 10 else 3.0
        pieces.append((5.0, lambda s, h=height: -h + 0.0 * s, lambda s: 0.0 * s))  # standing in air
        pieces.append((approach_s, lambda s, h=height, a=approach_s: -h + h * s / a, lambda s: 0.0 * s))
    else:
        raise ValueError(f"lead-in {lead_in!r}: one of {', '.join(LEAD_INS)}")
    g_prev, d_prev = 1.0 + relax, 0.0  # the first ramp loads the specimen at its instantaneous modulus
    for k in range(1, steps + 1):
        d_k = STEP_SIZE * k
        pieces.append(
            (
                ramp_s,
                lambda s, a=d_prev, b=d_k: a + (b - a) * s / ramp_s,
                lambda s, a=d_prev, b=d_k, g=g_prev: (
                    touch(a + (b - a) * s / ramp_s) * (g + (1.0 + relax - g) * s / ramp_s)
                ),
            )
        )
        pieces.append(
            (
                hold_s,
                lambda s, d=d_k: d + 0.0 * s,
                lambda s, d=d_k: touch(np.full_like(s, d)) * (1.0 + relax * np.exp(-s / tau_s)),
            )
        )
        g_prev, d_prev = 1.0 + relax * np.exp(-hold_s / tau_s), d_k
    pieces.append(
        (2.0, lambda s, a=d_prev: a - (a + 1.0) * s / 2.0, lambda s, a=d_prev: touch(a - (a + 1.0) * s / 2.0))
    )
    pieces.append((10.0, lambda s: -1.0 + 0.0 * s, lambda s: 0.0 * s))
    dt = 1.0 / rate_hz
    total = sum(p[0] for p in pieces)
    t = np.arange(0.0, total, dt)
    depth, force = np.zeros_like(t), np.zeros_like(t)
    start = 0.0
    for duration, d_of, f_of in pieces:
        sel = (t >= start - 1e-9 * dt) & (t < start + duration - 1e-9 * dt)
        depth[sel], force[sel] = d_of(t[sel] - start), f_of(t[sel] - start)
        start += duration
    f1 = float(hertz(np.array(STEP_SIZE)))
    force = force + drift_mN_per_s * t + noise * f1 * rng.standard_normal(len(t))
    record = pd.DataFrame({"Time [s]": t, "Position [mm]": POSITION0 - depth, "Force [N]": -force * 1e-3})
    return record, POSITION0


def as_record(frame: pd.DataFrame, path: str = "record.csv") -> LoadFrameRecord:
    """The record as :func:`find_holds` reads it (times s, positions mm, forces mN)."""
    return LoadFrameRecord(
        Path(path),
        frame["Time [s]"].to_numpy(),
        frame["Position [mm]"].to_numpy(),
        frame["Force [N]"].to_numpy() * 1e3,
        {"time": "Time [s]", "position": "Position [mm]", "force": "Force [N]"},
    )


def detect(lead_in: str, rate_hz: float, steps: int) -> dict:
    """One row of the table: holds found, the contact found and the depth error of every hold."""
    frame, contact = synthetic_record(lead_in, rate_hz, steps)
    record = as_record(frame)
    try:
        search = find_holds(record, STEP_SIZE, steps, RADIUS)
    except ExperimentDataError as exc:
        return {"holds": 0, "error": str(exc)}
    errors = []
    for h in search.holds:
        a, b = h.first_row - record.first_line, h.last_row - record.first_line
        true_depth = float(np.median(contact - record.position_mm[a : b + 1]))
        errors.append(h.depth_mm - true_depth)
    errors = np.asarray(errors)
    return {
        "holds": len(search.holds),
        "contact_error_mm": search.contact_position_mm - contact,
        "contact_from": search.contact_from,
        "max_depth_error_mm": float(np.abs(errors).max()),
        "steps_right": [h.step for h in search.holds] == list(range(1, steps + 1)),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rates", default="1,10,100", help="sampling rates, Hz")
    parser.add_argument("--steps", default="10,40", help="protocol lengths")
    args = parser.parse_args()
    rates = [float(v) for v in args.rates.split(",")]
    lengths = [int(v) for v in args.steps.split(",")]
    print(f"{'lead-in':<10} {'Hz':>5} {'steps':>5} {'found':>5} {'max |depth error| mm':>21}  contact from")
    worst, ok = 0.0, 0
    for lead_in in LEAD_INS:
        for rate in rates:
            for steps in lengths:
                row = detect(lead_in, rate, steps)
                if "error" in row:
                    print(f"{lead_in:<10} {rate:>5g} {steps:>5} {0:>5} {'refused':>21}  {row['error'][:90]}")
                    continue
                good = row["steps_right"] and row["max_depth_error_mm"] <= 0.01
                ok += good
                worst = max(worst, row["max_depth_error_mm"])
                print(
                    f"{lead_in:<10} {rate:>5g} {steps:>5} {row['holds']:>5} {row['max_depth_error_mm']:>21.5f}  "
                    f"{row['contact_from']}"
                )
    total = len(LEAD_INS) * len(rates) * len(lengths)
    print(
        f"{ok} of {total} records cut right (every step found, every depth within 0.01 mm); worst {worst:.5f} mm"
    )


if __name__ == "__main__":
    main()
