"""The offset between the DIC frames' time stamps and the load frame's record, found from the data:
frames taken all along (ramps seen) pin it to the sampling; frames taken only in the holds give a
range of offsets that fit as well, which holds the true one, and the frames chosen for the steps
are the true ones."""

from __future__ import annotations

import re

import numpy as np
import pytest
from lab_files import sampled_record

from indentation_studio.inference.experiment.data import ExperimentDataError
from indentation_studio.inference.lab.clock_offset import find_clock_offset, indentation_signal
from indentation_studio.inference.lab.dic_series import DICSeries, frames_by_time
from indentation_studio.inference.lab.load_frame import LoadFrameRecord, find_holds

TRUE_OFFSET = 12.3  # the DIC clock started 12.3 s after the load frame's


def _series(times_dic, record, search, offset=TRUE_OFFSET):
    """DIC frames whose field grows as depth^1.5 at the frames' true times on the record's clock."""
    rng = np.random.default_rng(1)
    base = rng.standard_normal((400, 3))
    depth = np.clip(search.position_sign * (record.position_mm - search.contact_position_mm), 0, None)
    d = np.interp(times_dic + offset, record.time_s, depth)
    u = d[:, None, None] ** 1.5 * base[None] * 0.1
    xyz = np.column_stack([rng.uniform(-5, 5, (400, 2)), np.zeros(400)])
    return DICSeries(
        "dic", xyz, u, np.arange(len(times_dic)), [str(i) for i in range(len(times_dic))], times_dic
    )


@pytest.fixture(scope="module")
def record():
    frame, _ = sampled_record(10, steps=5)
    rec = LoadFrameRecord(
        None,
        frame["Time [s]"].to_numpy(),
        frame["Position [mm]"].to_numpy(),
        frame["Force [N]"].to_numpy() * 1e3,
        {"force": "Force [N]"},
    )
    return rec, find_holds(rec, 0.5, 5, 4.77)


def test_offset_from_frames_taken_all_along(record):
    rec, search = record
    times = np.arange(0.0, rec.time_s[-1] - TRUE_OFFSET, 1.0)  # 1 frame/s on the DIC clock
    dic = _series(times, rec, search)
    depth = search.position_sign * (rec.position_mm - search.contact_position_mm)
    clock = find_clock_offset(dic.times_s, indentation_signal(dic), rec.time_s, depth, _windows(search))
    assert abs(clock.offset_s - TRUE_OFFSET) <= 0.1  # the record's sampling interval
    assert clock.power == pytest.approx(1.5)


def test_offset_from_frames_taken_in_the_holds_is_not_guessed(record):
    """One frame late in each hold, the cameras' clock 40 s behind: any offset that keeps every
    frame in its hold fits as well, a range of 30 s (the hold) in frames 32 s apart, without 0:
    refused with the range and the option."""
    rec, search = record
    ends = np.array([h.end_s for h in search.holds])
    times = np.concatenate([[5.0], ends - 3.0]) - 40.0  # a reference, then one frame late in each hold
    dic = _series(times, rec, search, offset=40.0)
    depth = search.position_sign * (rec.position_mm - search.contact_position_mm)
    args = (dic.times_s, indentation_signal(dic), rec.time_s, depth, _windows(search))
    with pytest.raises(ExperimentDataError) as caught:
        find_clock_offset(*args)
    msg = str(caught.value)
    assert "not decided by the data" in msg and "--time-offset" in msg
    low, high = (float(v) for v in re.search(r"offsets (\S+) \.\. (\S+) s", msg).groups())
    assert 0 < low <= 40.0 <= high and 20.0 <= high - low <= 30.0 + 1e-6  # the hold, less its frames' margin
    clock = find_clock_offset(*args, max_range_fraction=None)  # the range's middle, when asked for
    assert (clock.low_s, clock.high_s) == pytest.approx((low, high), abs=0.01)
    windows = np.array([(h.start_s, h.end_s) for h in search.holds])
    assert frames_by_time(dic, windows, clock.offset_s).tolist() == [1, 2, 3, 4, 5]


def test_offset_zero_when_the_range_holds_it(record):
    """The frames on the load frame's clock, late in each hold: 0 fits, and 0 is taken."""
    rec, search = record
    ends = np.array([h.end_s for h in search.holds])
    dic = _series(np.concatenate([[5.0], ends - 3.0]) - TRUE_OFFSET, rec, search)
    depth = search.position_sign * (rec.position_mm - search.contact_position_mm)
    clock = find_clock_offset(
        dic.times_s + TRUE_OFFSET, indentation_signal(dic), rec.time_s, depth, _windows(search)
    )
    assert clock.offset_s == 0.0 and clock.low_s <= 0.0 <= clock.high_s and clock.high_s - clock.low_s > 20.0
    assert "the clocks agree as far as the data tell" in clock.describe()


def _windows(search):
    return np.array([(h.start_s, h.end_s) for h in search.holds])
