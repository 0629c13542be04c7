"""CSV dialects: files written with semicolons and decimal commas (lab software under German, French
or Italian settings), with and without units in the header, read equal to the same data written
with commas and decimal points: the load frame's record, a force.csv in hold form (given to an
import, and in an experiment folder); the dialect detected or stated; a parse failure names the
dialect it tried."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "docs" / "figures"))
from guide_import_and_check_detection import synthetic_record

from indentation_studio.inference.experiment.data import ExperimentDataError, load_experiment
from indentation_studio.inference.lab.csv_text import csv_reading
from indentation_studio.inference.lab.experiment_import import (
    ForceSource,
    ProtocolInfo,
    _forces,
    import_load_frame,
)
from indentation_studio.inference.lab.load_frame import LoadFrameColumns
from indentation_studio.inference.lab.table_columns import read_table
from indentation_studio.studio.cli import app

ROOT = Path(__file__).resolve().parents[1]
PROTOCOL = ProtocolInfo(radius_mm=4.77, step_size_mm=0.5, steps=10)
PLAIN = {"Time [s]": "Time", "Position [mm]": "Position", "Force [N]": "Force"}
UNITS = LoadFrameColumns(time_unit="s", position_unit="mm", force_unit="N")


@pytest.fixture(scope="module")
def record():
    frame, _ = synthetic_record("contact", 10, 10)
    return frame


def _cut(path: Path, tmp: Path, columns: LoadFrameColumns | None = None) -> tuple[pd.DataFrame, dict]:
    out = tmp / f"{path.stem}-force.csv"
    result = import_load_frame(path, out, PROTOCOL, ForceSource(columns=columns or LoadFrameColumns()))
    return pd.read_csv(out), result


@pytest.mark.parametrize("units", [True, False], ids=["units in header", "no units"])
@pytest.mark.parametrize("sep", [";", "\t"], ids=["semicolon", "tab"])
def test_load_frame_european_equals_english(record, tmp_path, units, sep):
    frame = record if units else record.rename(columns=PLAIN)
    columns = LoadFrameColumns() if units else UNITS
    english = tmp_path / "english.csv"
    frame.to_csv(english, index=False)
    european = tmp_path / "european.csv"
    frame.to_csv(european, sep=sep, decimal=",", index=False)
    assert "0,0" in european.read_text()[:200]
    want, want_meta = _cut(english, tmp_path, columns)
    got, got_meta = _cut(european, tmp_path, columns)
    pd.testing.assert_frame_equal(got, want)
    assert [h["f_inf_mN"] for h in got_meta["holds"]] == [h["f_inf_mN"] for h in want_meta["holds"]]
    assert len(got) > 1000 and got["step"].max() == 10
    assert any("',' for decimals" in n for n in got_meta["notes"])


def test_dialect_stated(record, tmp_path):
    european = tmp_path / "european.csv"
    record.to_csv(european, sep=";", decimal=",", index=False)
    english = tmp_path / "english.csv"
    record.to_csv(english, index=False)
    with csv_reading(delimiter=";", decimal=","):
        got, _ = _cut(european, tmp_path)
    want, _ = _cut(english, tmp_path)
    pd.testing.assert_frame_equal(got, want)


def test_wrong_dialect_stated_is_named(record, tmp_path):
    european = tmp_path / "european.csv"
    record.to_csv(european, sep=";", decimal=",", index=False)
    with pytest.raises(ExperimentDataError, match=r"read with ',' between fields, '\.' for decimals"):
        with csv_reading(delimiter=",", decimal="."):
            _cut(european, tmp_path)


@pytest.mark.parametrize("header", ["step;time_s;force_mN", "step;time_s [s];force_mN [mN]"])
def test_force_csv_european_equals_english(tmp_path, header):
    english = ROOT / "examples" / "synthetic-12-250" / "force.csv"
    table = pd.read_csv(english)
    european = tmp_path / "force.csv"
    table.to_csv(european, sep=";", decimal=",", index=False, header=header.split(";"))
    got = read_table(european)
    assert list(got.columns) == header.split(";")
    np.testing.assert_array_equal(got.to_numpy(float), table.to_numpy(float))
    forces, *_ = _forces(ProtocolInfo(4.77, 0.5, 28), ForceSource(force_csv=european))
    np.testing.assert_array_equal(
        forces[["step", "time_s", "force_mN"]].to_numpy(float), table.to_numpy(float)
    )


def test_experiment_folder_with_a_european_force_csv(tmp_path):
    exp = tmp_path / "exp"
    shutil.copytree(ROOT / "examples" / "synthetic-12-250", exp)
    english = load_experiment(exp)
    table = pd.read_csv(exp / "force.csv")
    table.to_csv(exp / "force.csv", sep=";", decimal=",", index=False)
    european = load_experiment(exp)
    cols = ["step", "time_s", "force_mN"]
    np.testing.assert_array_equal(european.force[cols].to_numpy(float), english.force[cols].to_numpy(float))
    assert len(english.force) > 500


def test_cli_options(record, tmp_path):
    european = tmp_path / "european.csv"
    record.to_csv(european, sep=";", decimal=",", index=False)
    args = ["import", "load-frame", "--record", str(european), "--radius", "4.77", "--step-size", "0.5"]
    res = CliRunner().invoke(
        app, [*args, "--steps", "10", "--out", str(tmp_path / "f.csv"), "--delimiter", ";"]
    )
    assert res.exit_code == 0, res.output
    res = CliRunner().invoke(
        app, [*args, "--steps", "10", "--out", str(tmp_path / "g.csv"), "--decimal", "x"]
    )
    assert res.exit_code == 1 and "decimal separator 'x'" in res.output


def test_indenter_points_and_dic_csv_european_equal_english(tmp_path):
    from indentation_studio.inference.lab.experiment_import import IndenterSource, read_indenter_points
    from indentation_studio.inference.lab.import_csv import CSVMapping, read_dic_csv

    points = pd.read_csv(ROOT / "examples" / "lab-matchid" / "indenter.csv")
    points.to_csv(tmp_path / "english.csv", index=False)
    points.to_csv(tmp_path / "european.csv", sep=";", decimal=",", index=False)
    want = read_indenter_points(IndenterSource(tmp_path / "english.csv", "mm"))
    got = read_indenter_points(IndenterSource(tmp_path / "european.csv", "mm"))
    np.testing.assert_array_equal(got, want)
    assert want.shape == (len(points), 3)
    rng = np.random.default_rng(0)
    frame = pd.DataFrame(
        rng.normal(size=(50, 6)), columns=["X [mm]", "Y [mm]", "Z [mm]", "U [mm]", "V [mm]", "W [mm]"]
    )
    for name, kwargs in (("en", {}), ("eu", {"sep": ";", "decimal": ","})):
        (tmp_path / name).mkdir()
        for k in range(3):
            (frame * k).to_csv(tmp_path / name / f"B{k:05d}.csv", index=False, **kwargs)
    mapping = CSVMapping.parse("x=X,y=Y,z=Z,ux=U,uy=V,uz=W")
    en, eu = read_dic_csv(tmp_path / "en", mapping), read_dic_csv(tmp_path / "eu", mapping)
    np.testing.assert_array_equal(eu.u, en.u)
    np.testing.assert_array_equal(eu.xyz, en.xyz)
