"""The shipped lab example (``examples/lab-matchid``, made by ``tools/make_lab_example.py``
with the studio's own model at (c1, c5) = (12, 250) kPa): a MatchID export in camera coordinates,
a 100 Hz Instron-style load-frame record with holds, drift and a load-cell spike, the indenter's
points and the images' time stamps on a clock 23.6 s ahead. The three commands of the quick
path, ``import matchid``, ``check`` and ``fit``, run on it as they stand (the fit here with a
9-point GP of the paper's protocol, where the quick start uses the demo's surrogate)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from indentation_studio.campaign.runner import run_named_campaign
from indentation_studio.forward.spec import MeshChoice, ModelSpec
from indentation_studio.studio.cli import app
from indentation_studio.surrogate.persistence import save_surrogate
from indentation_studio.surrogate.training import train_surrogate

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "lab-matchid"


def _run(*args):
    res = CliRunner().invoke(app, [*args, "--json"])
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


def test_lab_example_is_small_and_says_how_it_was_made():
    size = sum(p.stat().st_size for p in EXAMPLE.rglob("*") if p.is_file())
    assert size <= 5 * 2**20, size
    about = json.loads((EXAMPLE / "lab.json").read_text())
    assert about["theta_kPa"] == [12.0, 250.0] and about["load_frame"]["rate_hz"] == 100.0
    assert len(list((EXAMPLE / "matchid").glob("Image_*_0.tiff.csv"))) == 29


def _import(out: Path, offset: bool = True) -> dict:
    about = json.loads((EXAMPLE / "lab.json").read_text())
    return (_run if offset else _refused)(
        *(
            "import",
            "matchid",
            "--dic",
            str(EXAMPLE / "matchid"),
            "--load-frame",
            str(EXAMPLE / "load_frame.csv"),
        ),
        *("--frame-times", str(EXAMPLE / "frame_times.csv"), "--indenter", str(EXAMPLE / "indenter.csv")),
        *("--radius", "4.77", "--step-size", "0.5", "--steps", "28"),
        *("--fiber-angle", str(about["fiber_angle_deg_as_the_camera_sees_it"]), "--out", str(out)),
        *(("--time-offset", str(about["camera"]["clock_offset_s"])) if offset else ()),
    )


def _refused(*args):
    res = CliRunner().invoke(app, [*args, "--json"])
    assert res.exit_code == 1, res.output
    return json.loads(res.stdout)


def test_lab_example_clock_offset_not_guessed(tmp_path):
    """The images were taken late in each hold: the offsets that keep every image in its hold fit
    as well (10 s of the 11 s between images); the import refuses to pick one and names the option."""
    error = _import(tmp_path / "lab", offset=False)["error"]
    assert "not decided by the data: offsets -32.09 .. -22.11 s" in error and "--time-offset" in error
    assert not (tmp_path / "lab").exists()


def test_lab_example_import_and_check(tmp_path):
    about = json.loads((EXAMPLE / "lab.json").read_text())
    imported = _import(tmp_path / "lab")
    assert imported["frames"] == list(range(1, 29)) and len(imported["holds"]) == 28
    assert all(h["readings"] >= 995 for h in imported["holds"])  # 10 s at 100 Hz, no ramp reading
    f = np.array([h["f_inf_mN"] for h in imported["holds"]])
    np.testing.assert_allclose(f, about["static_force_mN"], rtol=3e-3)  # drift taken off, spike ignored
    notes = " ".join(imported["notes"])
    assert (
        "6 lines of header block skipped" in notes and "drift" in notes and "offset -23.6 s (given)" in notes
    )
    meta = json.loads((tmp_path / "lab" / "experiment.json").read_text())["imported"]
    assert meta["load_frame"]["contact_from"] == "force onset"
    assert abs(meta["load_frame"]["contact_position_mm"] - 37.5) < 0.02
    clock = meta["clock_offset"]
    assert clock["source"] == "given" and clock["offset_s"] == about["camera"]["clock_offset_s"]
    check = _run("check", "--experiment", str(tmp_path / "lab"))
    assert check["clock_offset"] == "DIC clock offset -23.6 s (given: --time-offset)."
    assert check["fiber_text"].startswith("Fiber direction 120.48 deg in the DIC frame (declared")
    assert f"{check['fiber_angle_deg']:.2f} deg in the leveled frame" in check["fiber_text"]
    assert check["warnings"] == []
    reg = check["registration"]
    assert reg["tilt_deg"] == pytest.approx(12.0, abs=0.05)
    np.testing.assert_allclose(reg["origin_mm"], about["camera"]["indentation_point_mm"], atol=0.02)
    assert abs(check["fiber_angle_from_strain_deg"] - check["fiber_angle_deg"]) < 3.0


@pytest.mark.slow
def test_lab_example_three_commands_to_a_fit(tmp_path):
    spec = ModelSpec(mesh=MeshChoice("default"))  # the paper's protocol and mesh, 9 points
    # one process: the suite's two workers already take CI's two cores
    run_named_campaign("lab", "c1=8:16:3,c5=150:350:3", spec, runs_dir=tmp_path / "runs", jobs=1)
    surrogate = save_surrogate(
        train_surrogate("lab", "gp", runs_dir=tmp_path / "runs"), tmp_path / "gp.safetensors"
    )
    _import(tmp_path / "lab")
    assert _run("check", "--experiment", str(tmp_path / "lab"))["warnings"] == []
    fit = _run("fit", "--experiment", str(tmp_path / "lab"), "--surrogate", str(surrogate), "--no-refine")
    theta = np.array([fit["c1"], fit["c5"]])
    print(
        f"lab example fit: c1 = {theta[0]:.3f} kPa +- {fit['c1_pct']:.2f} %, c5 = {theta[1]:.1f} kPa +- {fit['c5_pct']:.2f} %"
    )
    assert np.all(np.abs(theta / [12.0, 250.0] - 1) < 0.05)  # a 9-point GP
    assert fit["registration"]["tilt_deg"] == pytest.approx(12.0, abs=0.05)
