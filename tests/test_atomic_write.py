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
