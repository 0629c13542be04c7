"""The contact point of a load-frame record from the onset of a power law fitted to the loading,
whatever the lead-in (at the contact with and without a preload, an approach through air of 10 or
300 s), the rate (1 to 1,000 Hz) and the protocol's length, with a drifting load cell; holds that
do not fit the protocol from the contact found are refused with what was found and the option
that sets the contact (--contact-position). The records are docs/figures/guide_import_and_check_detection.py's."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "docs" / "figures"))
from guide_import_and_check_detection import POSITION0, STEP_SIZE, as_record, detect, hertz, synthetic_record

from indentation_studio.inference.experiment.data import ExperimentDataError
from indentation_studio.inference.lab.contact_onset import power_law_onset
from indentation_studio.inference.lab.load_frame import find_holds


@pytest.mark.parametrize(
    ("lead_in", "rate", "steps"),
    [
        ("preload", 1, 40),  # the record: 10 s at the contact with 12 mN, 40 steps, 1 Hz
        ("preload", 100, 10),
        ("contact", 1, 10),
        ("contact", 100, 10),
        ("air-10s", 10, 10),
        ("air-300s", 1, 10),
        ("air-300s", 100, 10),
        ("air-10s", 1000, 10),
    ],
)
def test_every_hold_found_within_10_um(lead_in, rate, steps):
    row = detect(lead_in, rate, steps)
    assert "error" not in row, row.get("error")
    assert row["holds"] == steps and row["steps_right"]
    assert row["max_depth_error_mm"] <= 0.01
    assert row["contact_from"] == ("first reading" if lead_in == "preload" else "force onset")


def test_onset_below_the_noise():
    """At 100 Hz the onset is found to a few microns, well inside the 0.04 mm where a force that
    clears 8 standard deviations of its noise first does (0.5 % of step 1's force)."""
    frame, contact = synthetic_record("air-10s", 100, 10)
    rec = as_record(frame)
    onset = power_law_onset(rec.time_s, rec.position_mm, rec.force_mN, STEP_SIZE, -1.0)
    assert abs(onset.position_mm - contact) < 0.003
    f1 = float(hertz(np.array(STEP_SIZE)))
    clears = (8 * 0.005 * f1 / (1.3 * float(hertz(np.array(1.0))))) ** (
        2 / 3
    )  # depth where 8 sigma is reached
    assert clears > 0.03
    assert "power law" in onset.notes[0]


@pytest.mark.parametrize(("rate", "steps"), [(10, 10), (1, 40)])
def test_preload_tared_and_not_taken_for_drift(rate, steps):
    frame, _ = synthetic_record("preload", rate, steps, drift_mN_per_s=0.0)
    search = find_holds(as_record(frame), STEP_SIZE, steps, 4.77)
    notes = " ".join(search.notes)
    assert "starts loaded" in notes and "12 mN above" in notes.replace("12.0", "12")
    assert search.tare_mN == pytest.approx(-12.0, abs=0.2)  # N negative in compression, read as mN
    assert abs(search.drift_mN_per_s) < 1e-3  # not the preload over the record's length
    f_inf = np.array([h.f_inf_mN for h in search.holds])
    pressed = (12.0 / float(hertz(np.array(1.0)))) ** (2 / 3)
    expected = hertz(pressed + STEP_SIZE * np.arange(1, steps + 1)) - 12.0
    np.testing.assert_allclose(f_inf, expected, rtol=0.01)


def test_wrong_contact_refused_with_what_was_found_and_the_option():
    frame, contact = synthetic_record("contact", 10, 10)
    with pytest.raises(ExperimentDataError) as caught:
        find_holds(as_record(frame), STEP_SIZE, 10, 4.77, contact_position_mm=contact + 0.2)
    msg = str(caught.value)
    assert "a slipped step?" in msg and "--contact-position" in msg
    assert f"a contact at {POSITION0:g} mm fits them" in msg


def test_too_many_holds_names_the_option():
    frame, _ = synthetic_record("contact", 10, 10)
    with pytest.raises(
        ExperimentDataError, match=r"found 10 holds but the protocol has 9 steps.*--contact-position"
    ):
        find_holds(as_record(frame), STEP_SIZE, 9, 4.77)
