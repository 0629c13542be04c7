"""FEBio steps off equilibrium: flagged by depth, NaN in every force, rerun, read back, campaigns.

The bad logs are FEBio's baseline log with the indenter's Fz of one or two must points replaced
by the values a real FEBio 4 run returned off equilibrium (5.9e5 mN at 5.0 mm, 8.7e8 mN at
7.5 mm for the whole specimen) while the bottom reactions stay as they were.
"""

from __future__ import annotations

import json
import re
import stat
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from conftest import FEBIO_FEB as FEB
from conftest import FEBIO_LOG as LOG
from conftest import FEBIO_NPZ as NPZ
from typer.testing import CliRunner

from indentation_studio.campaign.designs import Design
from indentation_studio.campaign.errors import CampaignError
from indentation_studio.campaign.loader import force_table, load_campaign
from indentation_studio.campaign.runner import run_campaign
from indentation_studio.campaign.spec import CampaignSpec
from indentation_studio.campaign.store import CampaignStore
from indentation_studio.forward.febio.equilibrium import (
    EquilibriumTolerance,
    check_equilibrium,
    equilibrium_notes,
    off_equilibrium_steps,
)
from indentation_studio.forward.febio.log import febio_result, read_febio_log
from indentation_studio.forward.febio.readback import read_febio_run
from indentation_studio.forward.febio.runner import FebioSolver
from indentation_studio.forward.febio.writer import FebSettings
from indentation_studio.forward.result import SimulationResult
from indentation_studio.forward.spec import MeshChoice, ModelSpec
from indentation_studio.studio.cli import app

needs_baseline = pytest.mark.skipif(
    not LOG.is_file(), reason="../shared/febio/baseline (FEBio's real run) is not beside the clone"
)
#: Whole-specimen forces FEBio returned at steps it accepted off equilibrium, by time (= step).
BAD_FORCES = {10: 5.9e5, 15: 8.7e8}  # 5.0 mm and 7.5 mm


def altered_log(folder: Path, forces: dict[int, float] = BAD_FORCES, name: str = "bad.log") -> Path:
    """The baseline log with the indenter's Fz at the given must points set to -force / 4."""
    text = LOG.read_text(encoding="latin-1")
    for time, force in forces.items():
        record = re.compile(rf"(Time = {time}\nData = indenter\n\d+ \S+ \S+ \S+ )(\S+)\n")
        text, n = record.subn(lambda m, f=force: f"{m.group(1)}{-f / 4!r}\n", text)
        assert n == 1, f"no indenter record at time {time}"
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(text, encoding="latin-1")
    return path


def baseline_spec() -> ModelSpec:
    return ModelSpec(mesh=MeshChoice(feb_file=str(FEB)))


@pytest.fixture(scope="module")
def baseline_log():
    return read_febio_log(LOG)


def baseline_log_result(log):
    return febio_result(log, None, steps=28)


def test_tolerance_relative_absolute_and_non_finite():
    tol = EquilibriumTolerance(relative=3e-3, absolute_mN=0.01)
    bottom = np.array([0.0, 0.004, 1000.0, 1000.0, 1000.0, 1000.0, 1000.0])
    force = np.array([0.0, 0.013, 1002.9, 1003.1, 996.9, np.nan, 5.9e5])
    flags = off_equilibrium_steps(force, bottom, tol)
    # 0/0 and 9 micronewtons are under the floor; 0.29 % passes, 0.31 % either way fails
    assert flags.tolist() == [False, False, False, True, True, True, True]
    with pytest.raises(ValueError, match="relative"):
        EquilibriumTolerance(relative=0.0)


@needs_baseline
def test_baseline_flags_only_12_5_mm_and_keeps_11_5_mm(baseline_log):
    """Clean steps balance to < 4e-5; 11.5 mm (-0.09 %) is kept, 12.5 mm (-0.85 %) is flagged."""
    ref = np.load(NPZ)
    r = febio_result(baseline_log, None, steps=28)
    assert r.off_equilibrium.sum() == 1 and r.off_equilibrium[25]
    assert r.off_equilibrium_depths == [pytest.approx(12.5)]
    imbalance = r.convergence["equilibrium_imbalance"]
    assert imbalance[23] == pytest.approx(-8.748e-4, rel=1e-3)  # 11.5 mm, kept
    assert imbalance[25] == pytest.approx(-8.483e-3, rel=1e-3)  # 12.5 mm, flagged
    assert np.abs(np.delete(imbalance, [23, 25])).max() < 4e-5
    keep = np.arange(29) != 25
    np.testing.assert_array_equal(r.force[keep], ref["F_full"][keep])
    assert np.isnan(r.force[25]) and np.isnan(r.force_quarter[25])
    np.testing.assert_array_equal(r.convergence["indenter_reaction_quarter"], ref["F_quarter"])
    # a looser tolerance keeps 12.5 mm too (the check starts again from FEBio's numbers)
    loose = check_equilibrium(r, EquilibriumTolerance(relative=0.01))
    np.testing.assert_array_equal(loose.force, ref["F_full"])
    assert loose.off_equilibrium_depths == []


@needs_baseline
def test_altered_log_flags_the_altered_steps_and_returns_the_others_as_before(tmp_path, baseline_log):
    before = read_febio_run(LOG, baseline_spec())
    after = read_febio_run(altered_log(tmp_path), baseline_spec())
    assert after.off_equilibrium_depths == [5.0, 7.5, 12.5]  # 12.5: the baseline's own (above)
    assert np.isnan(after.force[[10, 15, 25]]).all()
    keep = np.ones(29, bool)
    keep[[10, 15, 25]] = False
    np.testing.assert_array_equal(after.force[keep], before.force[keep])
    np.testing.assert_array_equal(after.displacement, before.displacement)
    assert after.convergence["indenter_reaction_quarter"][10] == pytest.approx(5.9e5 / 4)
    assert after.convergence["equilibrium_imbalance"][15] == pytest.approx(8.7e8 / 5878.9 - 1, rel=1e-3)
    # the result file carries the flags; a file without them (older) still loads
    loaded = SimulationResult.load(after.save(tmp_path / "bad.npz"))
    np.testing.assert_array_equal(loaded.off_equilibrium, after.off_equilibrium)
    np.testing.assert_array_equal(loaded.force, after.force)
    old = SimulationResult.load(replace(after, off_equilibrium=None).save(tmp_path / "old.npz"))
    assert old.off_equilibrium is None and old.off_equilibrium_depths == []


@needs_baseline
def test_read_back_refuses_a_log_of_another_model(tmp_path):
    spec = baseline_spec()
    with pytest.raises(ValueError, match=r"c5 = 350 kPa, the spec's 300 kPa"):
        read_febio_run(LOG, spec.with_material(c5=300.0))
    with pytest.raises(ValueError, match=r"the run has 28 steps, the spec 20"):
        read_febio_run(LOG, replace(spec, protocol=replace(spec.protocol, steps=20)))
    with pytest.raises(ValueError, match=r"step 1: the indenter is 0.5 mm deep, the spec's depth is 0.4"):
        read_febio_run(LOG, replace(spec, protocol=replace(spec.protocol, step_size=0.4)))


@needs_baseline
def test_cli_from_log_prints_null_and_names_the_depths_on_stderr(tmp_path):
    bad = altered_log(tmp_path)
    out = tmp_path / "r.npz"
    args = ["simulate", "--from-log", str(bad), "--mesh-from", str(FEB), "--out", str(out), "--json"]
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 0, res.output
    assert "NaN" not in res.stdout
    payload = json.loads(res.stdout)
    ref = np.load(NPZ)["F_full"]
    assert [payload["force_mN"][k] for k in (10, 15, 25)] == [None, None, None]
    assert payload["force_mN"][9] == ref[9] and payload["force_mN"][28] == ref[28]
    assert payload["off_equilibrium_depths_mm"] == [5.0, 7.5, 12.5]
    assert "off equilibrium" in res.stderr and "at depth 5, 7.5, 12.5 mm" in res.stderr
    assert SimulationResult.load(out).off_equilibrium_depths == [5.0, 7.5, 12.5]


def _fake_febio(folder: Path, first_log: Path, rerun_log: Path | None) -> Path:
    """A febio4 that writes ``first_log`` as model.log, or ``rerun_log`` when the .feb asks for
    a residual tolerance (the tightened rerun); no rerun log: the rerun ends in error."""
    folder.mkdir(parents=True, exist_ok=True)
    rerun = "None" if rerun_log is None else repr(str(rerun_log))
    exe = folder / "febio4"
    exe.write_text(
        f"#!{sys.executable}\n"
        "import pathlib, shutil, sys\n"
        "feb = pathlib.Path(sys.argv[sys.argv.index('-i') + 1])\n"
        f"source = {rerun} if '<rtol>1e-06</rtol>' in feb.read_text() else {str(first_log)!r}\n"
        "if source is None:\n"
        "    feb.with_suffix('.log').write_text(' E R R O R   T E R M I N A T I O N\\n')\n"
        "    sys.exit(1)\n"
        "shutil.copy(source, feb.with_suffix('.log'))\n"
    )
    exe.chmod(exe.stat().st_mode | stat.S_IXUSR)
    return exe


@needs_baseline
def test_rerun_with_tightened_settings_keeps_the_better_run(tmp_path):
    exe = _fake_febio(tmp_path / "bin", altered_log(tmp_path), LOG)
    r = FebioSolver(baseline_spec(), executable=exe, workdir=tmp_path / "run").run()
    rerun = r.solver["rerun"]
    assert rerun["first_off_equilibrium_depths_mm"] == [5.0, 7.5, 12.5]
    assert rerun["rerun_off_equilibrium_depths_mm"] == [12.5] and rerun["kept"] == "rerun"
    assert rerun["settings_changed"] == {
        "max_increment": [1.0, 0.5],
        "late_max_increment": [0.5, 0.25],
        "dtol": [0.001, 0.0001],
        "etol": [0.01, 0.001],
        "rtol": [0.0, 1e-06],
    }
    assert r.solver["log_file"] == str(tmp_path / "run" / "rerun" / "model.log")
    assert r.solver["settings"] == FebSettings().tightened().__dict__
    np.testing.assert_array_equal(r.force, read_febio_run(LOG, baseline_spec()).force)
    feb = (tmp_path / "run" / "rerun" / "model.feb").read_text()
    notes = equilibrium_notes(r)
    assert "reran with tightened settings" in notes[0] and notes[0].endswith("kept the rerun run")
    assert notes[1].startswith("FEBio accepted 1 step(s) off equilibrium") and "at depth 12.5 mm" in notes[1]
    assert "<pt>0,0.5</pt>" in feb and "<pt>28,0.25</pt>" in feb and "<dtol>0.0001</dtol>" in feb


@needs_baseline
def test_failed_rerun_keeps_the_first_run_with_its_flags(tmp_path):
    exe = _fake_febio(tmp_path / "bin", altered_log(tmp_path), None)
    r = FebioSolver(baseline_spec(), executable=exe, workdir=tmp_path / "run").run()
    assert r.off_equilibrium_depths == [5.0, 7.5, 12.5] and r.solver["rerun"]["kept"] == "first"
    assert r.solver["rerun"]["outcome"].startswith("rerun failed: FEBio run failed (error termination)")


def _febio_campaign(tmp_path, first_log, rerun_log, name="fe", equilibrium_rel=None):
    exe = _fake_febio(tmp_path / "bin", first_log, rerun_log)
    design = Design(np.array([[10.0, 350.0]]), ("c1", "c5"), "baseline")
    extra = {} if equilibrium_rel is None else {"equilibrium_rel": equilibrium_rel}
    spec = CampaignSpec(name, design, baseline_spec(), "febio", extra)
    return exe, CampaignStore.create_or_open(tmp_path / "runs", spec)


@needs_baseline
def test_campaign_point_with_the_baselines_flagged_step_is_done_with_that_step_null(tmp_path, monkeypatch):
    """The shipped FEBio run's 12.5 mm step (imbalance 0.85 % of its own force) flagged with a
    0.5 % tolerance: the point is done, that step null, the rerun's cost recorded."""
    exe, store = _febio_campaign(tmp_path, LOG, LOG, equilibrium_rel=0.005)
    monkeypatch.setenv("FEBIO_PATH", str(exe))
    summary = run_campaign(store)
    assert (summary["done"], summary["failed"], summary["pending"]) == (1, 0, 0)
    assert summary["done_with_flagged_steps"] == 1 and summary["flagged_steps"] == 1
    assert summary["febio_reruns"] == 1 and summary["febio_rerun_s"] > 0  # flagged: the rerun ran
    r = SimulationResult.load(store.result_path(0))
    assert r.off_equilibrium_depths == [12.5] and np.isnan(r.force[25])
    assert np.all(np.isfinite(np.delete(r.force, 25)))
    assert r.solver["equilibrium"]["relative_tol"] == 0.005 and r.solver["rerun"]["kept"] == "first"
    assert not store.partial_path(0).exists()
    data = load_campaign(store.root)  # the point is kept, its step marked missing
    assert (
        data.points.tolist() == [0]
        and np.isnan(data.force[0, 24])
        and data.missing[0].tolist().count(True) == 1
    )
    table = force_table(store)  # the export: null at 12.5 mm
    assert table.loc[table.step == 25, "force_mN"].isna().all() and table["force_mN"].notna().sum() == 28
    res = CliRunner().invoke(
        app, ["campaign", "status", "--name", "fe", "--runs-dir", str(tmp_path / "runs")]
    )
    assert res.exit_code == 0 and "1 done, 1 steps flagged off equilibrium" in res.stdout, res.output
    with pytest.raises(CampaignError, match=r"different equilibrium tolerance \(0\.005 vs 0\.02\)"):
        CampaignStore.create_or_open(tmp_path / "runs", replace(store.spec, extra={}))


@needs_baseline
def test_campaign_default_tolerance_is_2_percent_of_the_steps_own_force_and_reruns_only_when_flagged(
    tmp_path, monkeypatch
):
    exe, store = _febio_campaign(tmp_path, LOG, None, name="clean")
    monkeypatch.setenv("FEBIO_PATH", str(exe))
    summary = run_campaign(store)  # 12.5 mm: 0.85 % < 2 %: kept, nothing flagged, no rerun
    assert summary["done"] == 1 and summary["flagged_steps"] == 0 and summary["febio_reruns"] == 0
    r = SimulationResult.load(store.result_path(0))
    assert np.all(np.isfinite(r.force)) and "rerun" not in r.solver
    assert not (store.root / "febio" / "00000" / "rerun").exists()
    # steps off by orders of magnitude (5.0 and 7.5 mm) are flagged at 2 % too; the failed rerun
    # keeps the first run: the point is done with those two steps null, not failed
    exe, bad = _febio_campaign(tmp_path / "b", altered_log(tmp_path), None, name="bad")
    monkeypatch.setenv("FEBIO_PATH", str(exe))
    summary = run_campaign(bad)
    assert summary["done"] == 1 and summary["failed"] == 0 and summary["flagged_steps"] == 2
    assert SimulationResult.load(bad.result_path(0)).off_equilibrium_depths == [5.0, 7.5]


@needs_baseline
def test_loader_keeps_points_with_flagged_steps_and_training_fills_them(tmp_path, baseline_log):
    from indentation_studio.surrogate.base import TrainingData

    design = Design(np.array([[10.0, 350.0], [10.0, 351.0], [10.0, 352.0]]), ("c1", "c5"), "three")
    store = CampaignStore.create_or_open(
        tmp_path / "runs", CampaignSpec("ld", design, baseline_spec(), "febio")
    )
    loose = febio_result(baseline_log, None, steps=28, tolerance=EquilibriumTolerance(relative=0.01))
    loose.save(store.result_path(0))  # complete curve
    febio_result(baseline_log, None, steps=28).save(store.result_path(1))  # NaN at 12.5 mm
    old = replace(loose, off_equilibrium=None, solver={"name": "febio"})  # written before the check
    old.save(store.result_path(2))
    store = CampaignStore.open(store.root)  # the files adopted: checked to load, hashed, done
    assert store.counts()["done"] == 3 and sorted(store.hashed_now) == [0, 1, 2]
    data = load_campaign(store.root)
    assert data.points.tolist() == [0, 1, 2] and data.left_out == {}
    assert data.missing[:, 24].tolist() == [False, True, True] and data.missing.sum() == 2
    assert np.isnan(data.force[1:, 24]).all() and np.isfinite(data.force[0]).all()
    train = TrainingData.from_campaign(data)  # the missing step filled from its own neighbours
    assert np.all(np.isfinite(train.force)) and train.missing.sum() == 2
    # FEBio's indenter force there is 0.9 % off; the bottom reaction (at equilibrium) is the truth
    bottom = 4 * np.asarray(baseline_log_result(baseline_log).convergence["bottom_reaction_quarter"])[25]
    np.testing.assert_allclose(train.force[1:, 24], bottom, rtol=1e-3)
    assert abs(data.force[0, 24] / bottom - 1) > 5e-3  # the flagged value itself is further off
    np.testing.assert_array_equal(train.force[:, :24], data.force[:, :24])
    table = force_table(store)  # the export shows the old file's 12.5 mm as NaN too
    assert table.loc[(table.point == 2) & (table.step == 25), "force_mN"].isna().all()
    assert table.loc[(table.point == 0) & (table.step == 25), "force_mN"].notna().all()


def test_febio_run_as_a_dic_like_experiment_leaves_out_the_step_off_equilibrium(tmp_path, febio_baseline):
    from indentation_studio.forward.predictor import Prediction
    from indentation_studio.inference.experiment.data import load_experiment
    from indentation_studio.inference.experiment.febio import RecordedRun, experiment_from_febio_run
    from indentation_studio.inference.experiment.processing import static_forces
    from indentation_studio.inference.experiment.synthetic import LAB_RECORDING

    out = experiment_from_febio_run(
        febio_baseline / "baseline.log",
        tmp_path / "e",
        recording=replace(LAB_RECORDING, f_noise=0.001),
        seed=5,
    )
    meta = json.loads((out / "experiment.json").read_text())
    assert meta["excluded_steps"] == [25]  # 12.5 mm, FEBio's step off equilibrium
    src = meta["synthetic"]["source"]
    assert (src["c1"], src["c5"], src["kappa"]) == (10.0, 350.0, 1000.0)
    assert src["off_equilibrium_depths_mm"] == [12.5]
    # the contact FEBio ran with, as its .feb states it (not the studio's perfect stick)
    assert src["contact"]["febio"]["type"] == "sliding-elastic"
    assert src["contact"]["febio"]["fric_coeff"] == 1e8
    assert meta["synthetic"]["model"]["contact"] == src["contact"]
    exp = load_experiment(out)
    assert exp.synthetic == meta["synthetic"] and exp.excluded_steps == (25,)
    f_inf, _ = static_forces(exp)
    assert np.isnan(f_inf[24])
    spec = ModelSpec(mesh=MeshChoice(feb_file=str(febio_baseline / "baseline.feb")))
    logged = read_febio_run(febio_baseline / "baseline.log", spec)
    used = np.arange(28) != 24
    np.testing.assert_allclose(f_inf[used], logged.force[1:][used], rtol=3e-3)  # FEBio's forces, relaxed
    with pytest.raises(FileExistsError, match="already there"):
        experiment_from_febio_run(febio_baseline / "baseline.log", tmp_path / "e")
    recorded = RecordedRun(Prediction.from_results([logged], ("c1", "c5")), np.array([10.0, 350.0]), spec)
    with pytest.raises(ValueError, match="recorded run is at"):
        recorded.predict(np.array([10.0, 300.0]))
    res = CliRunner().invoke(
        app,
        [
            "import",
            "febio",
            "--log",
            str(febio_baseline / "baseline.log"),
            "--out",
            str(tmp_path / "c"),
            "--json",
        ],
    )
    assert res.exit_code == 0, res.output
    said = json.loads(res.stdout.strip().splitlines()[-1])
    assert said["excluded_steps"] == [25] and said["off_equilibrium_depths_mm"] == [12.5]
