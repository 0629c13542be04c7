"""Hold detection at any sampling rate: the same synthetic indentation (6 steps of 0.5 mm, ramps of
0.5 to 2 s, 30 s holds, load-cell drift, an approach from 1 mm above the specimen and a withdrawal)
written as load-frame records at 1, 10, 100 and 1,000 Hz: every hold found, no ramp reading in a
hold, each hold's eq. 9 force as the noise-free record's; the contact point from the force onset;
a record without holds refused with what the stage did."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from lab_files import sampled_record

from indentation_studio.inference.experiment.data import ExperimentDataError
from indentation_studio.inference.lab.experiment_import import ProtocolInfo, import_load_frame
from indentation_studio.inference.lab.load_frame import LoadFrameRecord, find_holds

RATES = (1, 10, 100, 1000)
DRIFT = 0.02  # mN/s: 4 mN over the record, 2.4 times step 1's force


def _record(frame, path="record.csv") -> LoadFrameRecord:
    return LoadFrameRecord(
        Path(path),
        frame["Time [s]"].to_numpy(),
        frame["Position [mm]"].to_numpy(),
        frame["Force [N]"].to_numpy() * 1e3,
        {"time": "Time [s]", "position": "Position [mm]", "force": "Force [N]"},
    )


@pytest.mark.parametrize("rate", RATES)
def test_every_hold_found_at_every_rate(rate):
    clean, F = sampled_record(rate, drift_mN_per_s=DRIFT)
    noisy, _ = sampled_record(rate, noise=0.005, position_noise_mm=5e-4, drift_mN_per_s=DRIFT, seed=rate)
    exact = find_holds(_record(clean), 0.5, 6, 4.77)
    found = find_holds(_record(noisy), 0.5, 6, 4.77)
    for search in (exact, found):
        assert [h.step for h in search.holds] == [1, 2, 3, 4, 5, 6]
        assert search.contact_from == "force onset" and abs(search.contact_position_mm - 37.5) < 0.01
        assert search.drift_mN_per_s == pytest.approx(-DRIFT, rel=0.05)  # the record's sign: N, tension +
    # the ramps' readings are never in a hold: each starts when the stage stops (at most a
    # reading's worth of ramp, 1 ms at 1 kHz, inside the position's noise band)
    dt = 1.0 / rate
    ramps = np.array([0.5, 1.0, 1.5, 2.0, 0.5, 1.0])
    stops = 2.0 + 10.0 + np.cumsum(ramps) + 30.0 * np.arange(6)
    starts = np.array([h.start_s for h in exact.holds])
    assert np.all(starts >= stops - 2.0 * dt - 1e-9) and np.all(starts <= stops + dt + 1e-9)
    f_exact = np.array([h.f_inf_mN for h in exact.holds])
    np.testing.assert_allclose(f_exact, F, rtol=1e-6)  # noise-free: eq. 9 recovers F exactly
    f = np.array([h.f_inf_mN for h in found.holds])
    sd = np.array([h.f_inf_std_mN for h in found.holds])
    # with 0.5 % noise, eq. 9's f_inf is as good as the readings allow: within 1e-3 relative of the
    # noise-free record's at 10 Hz and above; at 1 Hz (30 readings a hold) within 3 standard errors
    tol = np.maximum(1e-3, 3 * sd / f_exact) if rate == 1 else 1e-3
    assert np.all(np.abs(f / f_exact - 1) <= tol), np.abs(f / f_exact - 1)


def test_record_at_100_hz_through_a_file(tmp_path):
    frame, _ = sampled_record(100, noise=0.005, drift_mN_per_s=DRIFT, seed=3)
    frame.to_csv(tmp_path / "record.csv", index=False)
    out = import_load_frame(tmp_path / "record.csv", tmp_path / "force.csv", ProtocolInfo(4.77, 0.5, 6))
    assert [h["step"] for h in out["holds"]] == [1, 2, 3, 4, 5, 6]
    assert all(h["readings"] >= 2990 for h in out["holds"])
    assert out["contact_from"] == "force onset" and "drift" in " ".join(out["notes"])


def test_record_without_holds_at_100_hz(tmp_path):
    frame, _ = sampled_record(100)
    frame["Position [mm]"] = np.linspace(37.5 + 1.0, 37.5 - 3.0, len(frame))  # one slow ramp, never held
    frame.to_csv(tmp_path / "record.csv", index=False)
    with pytest.raises(ExperimentDataError, match=r"record.csv: no hold found.*stood still at none"):
        import_load_frame(tmp_path / "record.csv", tmp_path / "force.csv", ProtocolInfo(4.77, 0.5, 6))
    assert not (tmp_path / "force.csv").exists()


def test_holds_shorter_than_min_hold_named_with_their_levels():
    frame, _ = sampled_record(10, hold_s=4.0, steps=3)
    with pytest.raises(
        ExperimentDataError,
        match=r"no hold found.*stood still at 0 mm for 10 s, 0.5 mm for 4 s, 1 mm for 4 s, "
        r"1.5 mm for 4 s",
    ):
        find_holds(_record(frame), 0.5, 3, 4.77, min_hold_s=5.0)
    assert len(find_holds(_record(frame), 0.5, 3, 4.77, min_hold_s=3.0).holds) == 3


def test_cli_contact_given_and_encoding(tmp_path):
    import json

    from typer.testing import CliRunner

    from indentation_studio.studio.cli import app

    frame, _ = sampled_record(10, steps=3)
    frame.to_csv(tmp_path / "record.csv", index=False)
    args = [
        "import",
        "load-frame",
        "--record",
        str(tmp_path / "record.csv"),
        "--out",
        str(tmp_path / "f.csv"),
    ]
    args += ["--radius", "4.77", "--step-size", "0.5", "--steps", "3", "--json"]
    res = CliRunner().invoke(app, [*args, "--contact-position", "37.5", "--encoding", "cp1252"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    assert out["contact_from"] == "given" and out["contact_position_mm"] == 37.5 and len(out["holds"]) == 3
    res = CliRunner().invoke(app, [*args, "--encoding", "no-such-codec"])
    assert res.exit_code == 1 and "unknown encoding 'no-such-codec'" in json.loads(res.stdout)["error"]
