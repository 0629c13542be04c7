"""The load-frame import cuts every record shape a lab makes (issue 59, deliverable 5): 4 lead-ins x
1, 10, 100 Hz x 10 and 40 steps, and two records as European CSV exports (semicolons, decimal
commas) read from a file, each cut into holds whose depths are within 0.005 mm of the truth; a
contact that does not fit the steps is refused naming ``--contact-position``.

The records: steps of 0.5 mm (2 s ramps, 30 s holds relaxing by eq. 9 to Hertz's force of a 4.77 mm
sphere on 4 kPa, by 30 % with a 4 s time constant; the first ramp at the instantaneous modulus),
0.5 % force noise, a load cell drifting 0.002 mN/s, the withdrawal to 1 mm above the contact. The
lead-ins: ``contact`` (the stage waits 10 s at the contact), ``preload`` (it waits pressed in to a
12 mN preload, the lab's zero), ``air-10s`` (an approach through air from 2 mm above at 0.2 mm/s)
and ``air-300s`` (from 6 mm above at 0.02 mm/s: farther above the contact than 10 steps go below
it), both going on into step 1 without a stop.

    .venv/bin/python tests/test_load_frame_lead_ins.py   # the table: max |depth error| per record
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from indentation_studio.inference.lab.experiment_import import ProtocolInfo, import_load_frame
from indentation_studio.inference.lab.load_frame import ExperimentDataError, LoadFrameRecord, find_holds

STEP_MM, RADIUS_MM, MU_KPA = 0.5, 4.77, 4.0
CONTACT_MM = 37.5  # the stage's position at the contact (it falls into the specimen)
TOLERANCE_MM = 0.005
LEAD_INS = {"contact": None, "preload": None, "air-10s": (10.0, 0.2), "air-300s": (300.0, 0.02)}
GRID = [(lead, rate, steps) for lead in LEAD_INS for rate in (1, 10, 100) for steps in (10, 40)]
EUROPEAN = [("air-300s", 100, 10), ("air-10s", 10, 40)]


def _record(frame) -> LoadFrameRecord:
    """A load frame's record (force in mN) of a table with the columns of :func:`lead_in_record`."""
    return LoadFrameRecord(
        Path("record.csv"),
        frame["Time [s]"].to_numpy(),
        frame["Position [mm]"].to_numpy(),
        frame["Force [N]"].to_numpy() * 1e3,
        {"time": "Time [s]", "position": "Position [mm]", "force": "Force [N]"},
    )


def hertz(depth: np.ndarray) -> np.ndarray:
    """Hertz's force (mN) of the sphere at ``depth`` (mm)."""
    return 16.0 / 3.0 * MU_KPA * np.sqrt(RADIUS_MM) * np.clip(depth, 0.0, None) ** 1.5


def lead_in_record(lead_in: str, rate_hz: float, steps: int, seed: int = 0) -> pd.DataFrame:
    """A record (``Time [s]``, ``Position [mm]``, ``Force [N]`` negative in compression) of the
    module docstring's kind; its contact is at ``CONTACT_MM`` and step k's hold at k ``STEP_MM``."""
    ramp_s, hold_s, relax, tau_s = 2.0, 30.0, 0.3, 4.0
    pressed = (12.0 / float(hertz(np.array(1.0)))) ** (2.0 / 3.0) if lead_in == "preload" else 0.0
    pieces = []  # (duration, depth(s), force(s))
    if LEAD_INS[lead_in] is None:
        pieces.append((10.0, lambda s: 0.0 * s, lambda s: hertz(pressed + 0.0 * s)))
    else:
        duration, speed = LEAD_INS[lead_in]
        height = duration * speed
        pieces.append((5.0, lambda s: -height + 0.0 * s, lambda s: 0.0 * s))
        pieces.append((duration, lambda s: -height + speed * s, lambda s: 0.0 * s))
    gain, d_prev = 1.0 + relax, 0.0
    for k in range(1, steps + 1):
        d_k = STEP_MM * k

        def ramp_depth(s, a=d_prev, b=d_k):
            return a + (b - a) * s / ramp_s

        pieces.append(
            (
                ramp_s,
                ramp_depth,
                lambda s, g=gain, dd=ramp_depth: (
                    hertz(dd(s) + pressed) * (g + (1.0 + relax - g) * s / ramp_s)
                ),
            )
        )
        pieces.append(
            (
                hold_s,
                lambda s, d=d_k: d + 0.0 * s,
                lambda s, d=d_k: hertz(d + pressed + 0.0 * s) * (1.0 + relax * np.exp(-s / tau_s)),
            )
        )
        gain, d_prev = 1.0 + relax * np.exp(-hold_s / tau_s), d_k
    pieces.append(
        (
            2.0,
            lambda s, a=d_prev: a - (a + 1.0) * s / 2.0,
            lambda s, a=d_prev: hertz(a - (a + 1.0) * s / 2.0 + pressed),
        )
    )
    pieces.append((10.0, lambda s: -1.0 + 0.0 * s, lambda s: 0.0 * s))
    dt = 1.0 / rate_hz
    t = np.arange(0.0, sum(p[0] for p in pieces), dt)
    depth, force = np.zeros_like(t), np.zeros_like(t)
    start = 0.0
    for duration, depth_of, force_of in pieces:
        sel = (t >= start - 1e-9 * dt) & (t < start + duration - 1e-9 * dt)
        depth[sel], force[sel] = depth_of(t[sel] - start), force_of(t[sel] - start)
        start += duration
    noise = 0.005 * float(hertz(np.array(STEP_MM)))
    force = force + 0.002 * t + noise * np.random.default_rng(seed).standard_normal(t.size)
    return pd.DataFrame({"Time [s]": t, "Position [mm]": CONTACT_MM - depth, "Force [N]": -force * 1e-3})


def cut(
    lead_in: str, rate_hz: float, steps: int, folder: Path | None = None
) -> tuple[np.ndarray, float, str]:
    """The depths of the holds found (mm), the contact's error (mm) and how it was found: from the
    record in memory, or (``folder``) from its European CSV export through the import."""
    frame = lead_in_record(lead_in, rate_hz, steps)
    if folder is not None:
        path = folder / f"{lead_in}-{rate_hz}hz-{steps}.csv"
        frame.to_csv(path, sep=";", decimal=",", index=False)
        assert ";" in path.read_text()[:100] and "," in path.read_text().splitlines()[2]
        out = import_load_frame(path, folder / "force.csv", ProtocolInfo(RADIUS_MM, STEP_MM, steps))
        depths = np.array([h["depth_mm"] for h in out["holds"]])
        return depths, out["contact_position_mm"] - CONTACT_MM, out["contact_from"]
    record = _record(frame)
    search = find_holds(record, STEP_MM, steps, RADIUS_MM)
    assert [h.step for h in search.holds] == list(range(1, steps + 1))
    depths = np.array([h.depth_mm for h in search.holds])
    return depths, search.contact_position_mm - CONTACT_MM, search.contact_from


def depth_error(depths: np.ndarray) -> float:
    """The largest |depth error| (mm) of holds 1, 2, ... against k step sizes."""
    return float(np.max(np.abs(depths - STEP_MM * np.arange(1, depths.size + 1))))


@pytest.mark.parametrize(("lead_in", "rate_hz", "steps"), GRID, ids=[f"{a}-{b}hz-{c}" for a, b, c in GRID])
def test_every_lead_in_cut_within_5_um(lead_in, rate_hz, steps):
    depths, contact_error, how = cut(lead_in, rate_hz, steps)
    assert depths.size == steps
    assert depth_error(depths) <= TOLERANCE_MM, (depth_error(depths), contact_error, how)
    assert how == ("first reading" if lead_in == "preload" else "force onset") or abs(contact_error) < 1e-9


@pytest.mark.parametrize(
    ("lead_in", "rate_hz", "steps"), EUROPEAN, ids=[f"{a}-{b}hz-{c}" for a, b, c in EUROPEAN]
)
def test_european_exports_cut_within_5_um(tmp_path, lead_in, rate_hz, steps):
    depths, _, _ = cut(lead_in, rate_hz, steps, tmp_path)
    assert depths.size == steps and depth_error(depths) <= TOLERANCE_MM


def test_long_approach_from_above_counts_steps_into_the_specimen():
    """6 mm of approach above the contact, 5 mm of steps below it: the position's sign is the way
    the stage loaded the specimen, not its largest excursion from the contact."""
    depths, _, _ = cut("air-300s", 10, 10)
    assert np.all(depths > 0)


def test_contact_off_the_steps_refused_naming_the_option():
    frame = lead_in_record("air-300s", 10, 10)
    record = _record(frame)
    with pytest.raises(ExperimentDataError, match=r"a contact at 37.5 mm fits them.*--contact-position MM"):
        find_holds(record, STEP_MM, 10, RADIUS_MM, contact_position_mm=CONTACT_MM + 0.2)


if __name__ == "__main__":
    import tempfile

    print(f"{'lead-in':<9} {'Hz':>4} {'steps':>5}  {'max |depth error| mm':>20}  contact error mm (from)")
    rows = [(*g, None) for g in GRID] + [(*g, "European CSV") for g in EUROPEAN]
    with tempfile.TemporaryDirectory() as tmp:
        for lead_in, rate, steps, export in rows:
            try:
                depths, err, how = cut(lead_in, rate, steps, Path(tmp) if export else None)
                cell = f"{depth_error(depths):>20.4f}  {err:+.4f} ({how})"
            except (ExperimentDataError, AssertionError) as exc:
                cell = f"{'refused':>20}  {str(exc)[:150]}"
            print(f"{lead_in:<9} {rate:>4} {steps:>5}  {cell}{'  ' + export if export else ''}", flush=True)
