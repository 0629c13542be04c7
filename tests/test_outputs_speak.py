"""Outputs that speak: an import prints what it dropped (NaN rows inside a MatchID image) and how it
set the clocks' offset; check prints its report's path, the fiber direction in the frame it was
typed in and the other, named, and one line for each warning."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from indentation_studio.studio.cli import app

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "lab-matchid"


def _invoke(*args):
    res = CliRunner().invoke(app, list(args), env={"COLUMNS": "250"})
    assert res.exit_code == 0, res.output
    return res.output


@pytest.fixture(scope="module")
def imported(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("speak")
    dic = tmp / "matchid"
    shutil.copytree(EXAMPLE / "matchid", dic)
    frame = dic / "Image_0005_0.tiff.csv"
    lines = frame.read_text().splitlines()
    for i in (10, 11):  # file lines 11 and 12: the point's coordinates and displacements not correlated
        cells = lines[i].split(",")
        lines[i] = ",".join(cells[:2] + ["NaN"] * 6 + cells[8:])
    frame.write_text("\n".join(lines) + "\n")
    out = _invoke(
        *("import", "matchid", "--dic", str(dic), "--load-frame", str(EXAMPLE / "load_frame.csv")),
        *("--frame-times", str(EXAMPLE / "frame_times.csv"), "--time-offset", "-23.6"),
        *("--indenter", str(EXAMPLE / "indenter.csv"), "--radius", "4.77", "--step-size", "0.5"),
        *("--steps", "28", "--fiber-angle", "100", "--out", str(tmp / "lab")),
    )
    return tmp / "lab", out, len(lines) - 1


def test_import_names_the_rows_it_dropped(imported):
    _, out, rows = imported
    assert (
        "note: rows without coordinates or displacements (NaN: not correlated there) dropped in 1 image(s): "
        f"Image_0005_0.tiff.csv: 2 of {rows} (rows 11, 12)"
    ) in out
    assert "note: DIC clock offset -23.6 s (given)" in out
    assert "note: contact from a power law fitted to the loading" in out


def test_check_prints_its_report_fiber_and_warnings(imported):
    folder, _, _ = imported
    out = _invoke("check", "--experiment", str(folder), "--mesh", "coarse")
    assert f"wrote {folder / 'check' / 'index.html'}" in out
    assert "Fiber direction 100.00 deg in the DIC frame (declared: experiment.json, --fiber-angle)" in out
    assert "deg in the leveled frame" in out
    assert "DIC clock offset -23.6 s (given: --time-offset)." in out
    report = json.loads((folder / "check" / "check.json").read_text())
    warnings = report["warnings"]
    assert any("fiber direction" in w for w in warnings)  # 100 deg typed where the images show 120.48
    assert f"{len(warnings)} warning(s):" in out
    printed = [line for line in out.splitlines() if line.startswith("warning: ")]
    assert len(printed) == len(warnings) and all(len(line) <= 170 for line in printed)
