"""atomic_write: the whole file or the old one, never half; ordinary permissions."""

from __future__ import annotations

import json
import os
import stat

import pytest

from indentation_studio.atomic_write import atomic_write, atomic_write_json


def test_text_bytes_and_writer_functions_land_whole(tmp_path):
    assert atomic_write(tmp_path / "a" / "t.txt", "text").read_text() == "text"
    assert atomic_write(tmp_path / "b.bin", b"\x00\x01").read_bytes() == b"\x00\x01"
    assert atomic_write(tmp_path / "c.txt", lambda p: p.write_text("by writer")).read_text() == "by writer"
    assert json.loads(atomic_write_json(tmp_path / "d.json", {"x": 1.5}).read_text()) == {"x": 1.5}


def test_a_failing_writer_keeps_the_old_file_and_leaves_no_temporary(tmp_path):
    target = atomic_write(tmp_path / "r.txt", "old")

    def broken(path):
        path.write_text("half")
        raise RuntimeError("killed half-way")

    with pytest.raises(RuntimeError, match="half-way"):
        atomic_write(target, broken)
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.txt"]


def test_permissions_are_those_of_an_ordinary_file(tmp_path):
    ordinary = tmp_path / "ordinary.txt"
    ordinary.write_text("x")
    written = atomic_write(tmp_path / "atomic.txt", "x")
    assert stat.S_IMODE(os.stat(written).st_mode) == stat.S_IMODE(os.stat(ordinary).st_mode)


def test_json_is_strict_json_an_unbounded_number_null(tmp_path):
    import json

    import numpy as np

    from indentation_studio.atomic_write import atomic_write_json, strict_json

    payload = {"mu_pct": np.inf, "force": np.array([1.5, np.nan]), "n": np.int64(3), "ok": True}
    text = strict_json(payload)
    assert "Infinity" not in text and "NaN" not in text
    assert json.loads(text) == {"mu_pct": None, "force": [1.5, None], "n": 3, "ok": True}
    path = atomic_write_json(tmp_path / "r.json", payload | {"where": tmp_path})
    assert json.loads(path.read_text(), parse_constant=pytest.fail)["where"] == str(tmp_path)


def test_atomic_write_npz_round_trip_leaves_no_temporary(tmp_path):
    import numpy as np

    from indentation_studio.atomic_write import atomic_write_npz

    a = np.arange(12.0).reshape(3, 4)
    path = atomic_write_npz(tmp_path / "x.npz", a=a, b=np.array([1, 2]))
    with np.load(path) as z:
        assert np.array_equal(z["a"], a) and z["b"].tolist() == [1, 2]
    assert [p.name for p in tmp_path.iterdir()] == ["x.npz"]  # no .npz.npz, no *.tmp
