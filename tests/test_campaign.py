"""Campaigns: designs, the resumable store, kill and resume, failures, dask, the loader."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from dataclasses import replace

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from indentation_studio.campaign import executors
from indentation_studio.campaign.designs import (
    DesignError,
    design_from_option,
    paper_grid,
    parse_grid,
    points_from_csv,
    space_filling,
)
from indentation_studio.campaign.errors import CampaignError
from indentation_studio.campaign.loader import force_table, load_campaign
from indentation_studio.campaign.runner import run_campaign
from indentation_studio.campaign.spec import CampaignSpec
from indentation_studio.campaign.store import CampaignStore
from indentation_studio.forward.result import SimulationResult
from indentation_studio.forward.solver import EmbeddedSolver, SimulationError, simulate
from indentation_studio.forward.spec import MeshChoice, ModelSpec, Protocol
from indentation_studio.studio.cli import app
from indentation_studio.studio.figures import campaign_figure

SMALL = ModelSpec(protocol=Protocol(step_size=0.5, steps=2), mesh=MeshChoice("coarse"))
CLI = [sys.executable, "-m", "indentation_studio.studio.cli"]


def test_paper_grid_is_25_by_31_over_the_paper_box():
    d = paper_grid()
    assert d.points.shape == (775, 2) and d.parameters == ("c1", "c5")
    c1, c5 = np.unique(d.points[:, 0]), np.unique(d.points[:, 1])
    assert len(c1) == 25 and len(c5) == 31
    assert (c1[0], c1[-1], c5[0], c5[-1]) == (1.0, 21.0, 82.5, 578.0)
    np.testing.assert_allclose(np.diff(c1), 20 / 24)
    np.testing.assert_allclose(np.diff(c5), 495.5 / 30)


def test_user_grids_csv_and_space_filling_designs(tmp_path):
    g = parse_grid("c1=2:4:3,c5=100:200:2")
    np.testing.assert_allclose(g.points, [[2, 100], [2, 200], [3, 100], [3, 200], [4, 100], [4, 200]])
    with pytest.raises(DesignError, match="NAME=LO:HI:N"):
        parse_grid("c1=2:4")
    f = parse_grid("c1=2:4:2,c5=100:100:1,mu=0.25:4:5:log")  # friction as a third, log-spaced axis
    assert f.parameters == ("c1", "c5", "mu") and f.points.shape == (10, 3)
    np.testing.assert_allclose(f.points[:5, 2], [0.25, 0.5, 1, 2, 4])  # ratio (4/0.25)**(1/4) = 2
    np.testing.assert_allclose(f.points[5:, 0], 4)
    with pytest.raises(DesignError, match="LO > 0"):
        parse_grid("c1=2:4:2,mu=0:4:5:log")
    csv = tmp_path / "pts.csv"
    csv.write_text("c1,c5,note\n3,200,a\n4,x,b\n")
    with pytest.raises(DesignError, match=r"row 3, column 'c5'"):
        points_from_csv(csv)
    csv.write_text("c1,c2\n3,200\n")
    with pytest.raises(DesignError, match="missing column"):
        points_from_csv(csv)
    for kind in ("lhs", "sobol"):
        a, b = space_filling(kind, 16, seed=3), design_from_option(f"{kind}:16:3")
        np.testing.assert_array_equal(a.points, b.points)
        assert not np.array_equal(a.points, space_filling(kind, 16, seed=4).points)
        assert np.all((a.points >= [1, 82.5]) & (a.points <= [21, 578]))
    lhs = space_filling("lhs", 10, seed=1).points
    for j, (lo, hi) in enumerate([(1, 21), (82.5, 578)]):  # one point in each of the 10 strata
        strata = np.floor((lhs[:, j] - lo) / (hi - lo) * 10).astype(int)
        assert sorted(strata) == list(range(10))
    # friction as a third axis filled evenly in log: an LHS puts one point in each log stratum of
    # 0.1 .. 3, so 2/3 of them lie below 1 where slip changes the response
    mu = design_from_option("lhs:30:2,mu=0.1:3:log")
    assert mu.parameters == ("c1", "c5", "mu") and mu.description == "lhs:n=30:seed=2,mu=0.1:3:log"
    strata = np.floor(np.log(mu.points[:, 2] / 0.1) / np.log(30) * 30).astype(int)
    assert sorted(strata) == list(range(30))
    assert np.sum(mu.points[:, 2] < 1.0) in (20, 21)  # 30 log(10) / log(30) = 20.3 strata lie below 1
    assert np.all((mu.points[:, :2] >= [1, 82.5]) & (mu.points[:, :2] <= [21, 578]))
    narrowed = design_from_option("sobol:8:0,c1=2:5,mu=0.2:2")  # a range changed, mu linear
    assert np.all((narrowed.points[:, 0] >= 2) & (narrowed.points[:, 0] <= 5))
    assert narrowed.description == "sobol:n=8:seed=0,c1=2:5,mu=0.2:2"
    for bad, message in (
        ("sobol:8,mu=0:3:log", "LO > 0"),
        ("sobol:8,mu=3:1", "LO < HI"),
        ("lhs:8,mu", "NAME=LO:HI"),
    ):
        with pytest.raises(DesignError, match=message):
            design_from_option(bad)


def _spec(name: str, design: str, model: ModelSpec = SMALL) -> CampaignSpec:
    return CampaignSpec(name, design_from_option(design), model)


def test_store_refuses_a_different_spec(tmp_path):
    CampaignStore.create_or_open(tmp_path, _spec("a", "c1=2:4:2,c5=100:200:2"))
    CampaignStore.create_or_open(tmp_path, _spec("a", "c1=2:4:2,c5=100:200:2"))  # same: fine
    with pytest.raises(CampaignError, match="different design"):
        CampaignStore.create_or_open(tmp_path, _spec("a", "c1=2:4:3,c5=100:200:2"))
    with pytest.raises(CampaignError, match=r"different model protocol\.steps: 2 -> 3"):
        other = ModelSpec(protocol=Protocol(step_size=0.5, steps=3), mesh=MeshChoice("coarse"))
        CampaignStore.create_or_open(tmp_path, _spec("a", "c1=2:4:2,c5=100:200:2", other))


@pytest.mark.slow
def test_sigkill_then_resume_gives_every_point_once(tmp_path):
    args = [*CLI, "campaign", "run", "--name", "k", "--grid", "c1=3:15:4,c5=100:500:2", "--mesh", "coarse"]
    args += ["--steps", "3", "--jobs", "2", "--runs-dir", str(tmp_path), "--json"]
    points = tmp_path / "k" / "points"
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, start_new_session=True)
    deadline = time.time() + 240
    while time.time() < deadline and len(list(points.glob("[0-9]*.npz"))) < 2:
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)  # the whole process group: parent and workers
    proc.wait()
    before = sorted(p.name for p in points.glob("[0-9]*.npz"))
    assert 2 <= len(before) < 8, "the kill must land part way"
    out = subprocess.run(args, capture_output=True, text=True, timeout=600, check=True)
    summary = json.loads(out.stdout)
    assert summary["done"] == 8 and summary["failed"] == 0 and summary["pending"] == 0
    assert summary["solved_now"] == 8 - len(before)  # finished points were skipped
    files = sorted(p.name for p in points.iterdir())
    assert files == [f"{i:05d}.npz" for i in range(8)]  # each point exactly once, no temp files
    index = pd.read_parquet(tmp_path / "k" / "index.parquet")
    assert sorted(index["point"]) == list(range(8)) and set(index["status"].astype(str)) == {"done"}
    design = design_from_option("c1=3:15:4,c5=100:500:2").points
    for i in range(8):
        r = SimulationResult.load(points / f"{i:05d}.npz")
        assert (r.spec["material"]["c1"], r.spec["material"]["c5"]) == tuple(design[i])
        assert r.force[-1] > 0


def test_failed_points_are_recorded_and_the_rest_finish(tmp_path, monkeypatch):
    csv = tmp_path / "pts.csv"
    csv.write_text("c1,c5\n6,200\n0,200\n9,300\n12,250\n")  # c1 = 0 cannot be a material
    original = EmbeddedSolver.run

    def run(self, *args, **kwargs):  # a solver failure part way, for one point only
        if self.spec.material.c1 == 12:
            partial = original(EmbeddedSolver(replace(self.spec, protocol=Protocol(0.5, 1))))
            raise SimulationError("no convergence at 0.75 mm (forced)", 0.75, partial)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(EmbeddedSolver, "run", run)
    store = CampaignStore.create_or_open(tmp_path, _spec("f", str(csv)))
    summary = run_campaign(store, jobs=1)  # in-process, so the patched solver is used
    assert (summary["done"], summary["failed"], summary["pending"]) == (2, 2, 0)
    errors = {f["point"]: f["error"] for f in summary["failures"]}
    assert "material.c1" in errors[1] and "must be positive" in errors[1]
    assert "SimulationError" in errors[3] and "0.75 mm" in errors[3]
    assert SimulationResult.load(store.partial_path(3)).depth[-1] == 0.5  # what was solved is kept
    index = pd.read_parquet(tmp_path / "f" / "index.parquet")
    assert list(index["status"].astype(str)) == ["done", "failed", "done", "failed"]
    _check_campaign_figure(index, load_campaign("f", runs_dir=tmp_path))
    monkeypatch.setattr(EmbeddedSolver, "run", original)
    again = run_campaign(CampaignStore.open(tmp_path / "f"), jobs=1)
    assert again["solved_now"] == 0  # failed points wait for --retry-failed
    again = run_campaign(CampaignStore.open(tmp_path / "f"), jobs=1, retry_failed=True)
    assert (again["done"], again["failed"], again["solved_now"]) == (3, 1, 2)


def _check_campaign_figure(index: pd.DataFrame, data) -> None:
    """The campaign figure draws the done points where they are, coloured by their wall time, the
    failed ones as crosses, and the force of each done point (both are corners of their box)."""
    fig = campaign_figure(index, data)
    design, curves = fig.axes[0], fig.axes[1]
    done = index["status"].astype(str) == "done"
    dots, crosses = design.collections[:2]
    np.testing.assert_array_equal(dots.get_offsets(), index.loc[done, ["c1", "c5"]].to_numpy())
    np.testing.assert_array_equal(dots.get_array(), index.loc[done, "wall_s"].to_numpy())
    np.testing.assert_array_equal(crosses.get_offsets(), index.loc[~done, ["c1", "c5"]].to_numpy())
    assert design.get_title() == "design: 2 of 4 points done"
    assert [line.get_label().split(":")[0] for line in curves.lines] == ["point 0", "point 2"]
    for line, k in zip(curves.lines, (0, 1), strict=True):
        np.testing.assert_array_equal(line.get_xydata(), np.column_stack([data.depth, data.force[k]]))
    plt.close(fig)


def test_timeout_fails_points_and_retry_recovers(tmp_path):
    # the deadline is solve_point's, the same in every executor: here in this process (the worker
    # processes' start is the sigkill test's, and their failures the dask tests')
    store = CampaignStore.create_or_open(tmp_path, _spec("t", "c1=5:10:2,c5=200:200:1"))
    s = run_campaign(store, jobs=1, timeout_s=1e-6)
    assert s["failed"] == 2 and all("timeout" in f["error"] for f in s["failures"])
    s = run_campaign(CampaignStore.open(tmp_path / "t"), jobs=1, retry_failed=True)
    assert s["done"] == 2 and s["failed"] == 0


def test_a_point_stopped_after_a_step_resumes_there_with_the_uninterrupted_result(
    tmp_path, caplog, monkeypatch
):
    # the timeout stops the point after its first step (the deadline is checked after each step,
    # once the step's checkpoint is written: here after every step, as a point of hours writes
    # one every POINT_CHECKPOINT_S); the retry resumes from that step, not from the start
    monkeypatch.setattr(executors, "POINT_CHECKPOINT_S", 0.0)
    store = CampaignStore.create_or_open(tmp_path, _spec("r", "c1=6:6:1,c5=300:300:1"))
    s = run_campaign(store, jobs=1, timeout_s=1e-6)
    assert s["failed"] == 1 and "after step 1 of 2" in s["failures"][0]["error"]
    assert s["resumable"] == [0] and store.checkpoint_path(0).is_file()
    at = s["resumable_at"][0]  # where `campaign status` says it stands
    assert (at["point"], at["depth_mm"], at["of_mm"], at["steps_done"], at["steps"]) == (0, 0.5, 1.0, 1, 2)
    assert at["elapsed_s"] > 0
    # a failed point keeps its checkpoint, but a plain run does not resume it: status says so
    text = CliRunner().invoke(app, ["campaign", "status", "--name", "r", "--runs-dir", str(tmp_path)]).stdout
    assert "1 failed points resume from their last finished step only with --retry-failed: 0" in text
    assert "point 0 (failed) at its last checkpoint: 0.5 of 1 mm (1 of 2 steps)" in text
    assert "unfinished points resume" not in text
    with caplog.at_level("INFO", logger="indentation_studio.forward.solver"):
        s = run_campaign(CampaignStore.open(tmp_path / "r"), jobs=1, retry_failed=True)
    assert s["done"] == 1 and s["resumable"] == []
    assert "after step 1 (0.5 mm)" in caplog.text
    assert not store.checkpoint_path(0).exists()  # deleted once the result is kept
    # step 1 is the checkpoint's, bit for bit; step 2 within the Newton tolerance (residual 1e-4
    # of its scale: the resumed run has no factorisation to reuse, as simulate --restart's tests)
    resumed = SimulationResult.load(store.result_path(0))
    whole = EmbeddedSolver(SMALL.with_parameters(c1=6.0, c5=300.0)).run(threads=1)
    np.testing.assert_array_equal(resumed.force[:2], whole.force[:2])
    np.testing.assert_allclose(resumed.force, whole.force, rtol=1e-4)
    np.testing.assert_allclose(resumed.displacement, whole.displacement, atol=1e-4 * 1.0)


def test_a_point_of_seconds_writes_no_checkpoint(tmp_path):
    # stopped after its first step of well under POINT_CHECKPOINT_S: nothing written to resume from
    store = CampaignStore.create_or_open(tmp_path, _spec("q", "c1=6:6:1,c5=300:300:1"))
    s = run_campaign(store, jobs=1, timeout_s=1e-6)
    assert s["failed"] == 1 and s["resumable"] == [] and not store.checkpoint_path(0).exists()


def test_a_checkpoint_it_cannot_resume_from_is_kept_aside_and_the_point_solved_from_its_start(
    tmp_path, caplog
):
    store = CampaignStore.create_or_open(tmp_path, _spec("m", "c1=6:6:1,c5=300:300:1"))
    store.checkpoints_dir.mkdir()
    store.checkpoint_path(0).write_bytes(b"not a checkpoint")
    assert store.summary()["resumable_at"] == [{"point": 0, "unreadable": True}]
    with caplog.at_level("WARNING", logger="indentation_studio.campaign.executors"):
        s = run_campaign(store, jobs=1)
    assert s["done"] == 1 and s["resumable"] == []
    assert "00000.pkl is not a readable checkpoint" in caplog.text and "solved from its start" in caplog.text
    refused = store.checkpoints_dir / "00000.pkl.refused"
    assert refused.read_bytes() == b"not a checkpoint" and not store.checkpoint_path(0).exists()
    whole = EmbeddedSolver(SMALL.with_parameters(c1=6.0, c5=300.0)).run(threads=1)
    np.testing.assert_array_equal(SimulationResult.load(store.result_path(0)).force, whole.force)


def test_dask_localcluster_and_loader(tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        store = CampaignStore.create_or_open(tmp_path, _spec("d", "c1=4:12:2,c5=150:450:2"))
        s = run_campaign(store, scheduler=cluster.scheduler_address)
    assert s["done"] == 4 and s["failed"] == 0
    data = load_campaign("d", runs_dir=tmp_path)
    assert data.theta.shape == (4, 2) and data.force.shape == (4, 2)
    assert data.displacement.shape == (4, 2, len(data.top_xyz), 3)
    np.testing.assert_allclose(data.depth, [0.5, 1.0])
    direct = simulate(SMALL.with_material(c1=12.0, c5=450.0))
    k = int(np.nonzero((data.theta == [12.0, 450.0]).all(axis=1))[0][0])
    np.testing.assert_allclose(data.force[k], direct.force[1:], rtol=1e-9)
    np.testing.assert_allclose(data.displacement[k], direct.displacement[1:], atol=1e-12)
    table = force_table(CampaignStore.open(tmp_path / "d"))
    assert len(table) == 4 * 3 and list(table.columns) == [
        "point",
        "c1",
        "c5",
        "step",
        "depth_mm",
        "force_mN",
    ]


# ------------------------------------------------ nothing lost, nothing trusted blindly (issue 34)
def test_a_store_records_its_mesh_and_refuses_a_changed_one(tmp_path, monkeypatch):
    """A preset whose geometry changes keeps its name: the store names the change instead of
    mixing points of two meshes."""
    import dataclasses

    import indentation_studio.campaign.store as store_module
    from indentation_studio.forward.mesh import build_mesh

    store = CampaignStore.create_or_open(tmp_path, _spec("m", "c1=2:4:2,c5=100:200:2"))
    record = store.spec.extra["mesh"]
    assert record["nodes"] == build_mesh(SMALL).n_nodes and len(record["sha256"]) == 64
    assert json.loads((tmp_path / "m" / "campaign.json").read_text())["extra"]["mesh"] == record
    CampaignStore.create_or_open(tmp_path, _spec("m", "c1=2:4:2,c5=100:200:2"))  # same mesh: fine

    def moved(spec):  # the same preset, one top node moved by 0.1 mm
        mesh = build_mesh(spec)
        nodes = mesh.nodes.copy()
        nodes[mesh.top[1], 0] += 0.1
        return dataclasses.replace(mesh, nodes=nodes)

    monkeypatch.setattr(store_module, "build_mesh", moved)
    with pytest.raises(CampaignError, match=r"solved on another mesh.*sha256"):
        CampaignStore.create_or_open(tmp_path, _spec("m", "c1=2:4:2,c5=100:200:2"))


GRID = "c1=4:12:2,c5=150:450:2"


def _solved_store(tmp_path, name="h", grid=GRID):
    store = CampaignStore.create_or_open(tmp_path, _spec(name, grid))
    summary = run_campaign(store, jobs=1)
    assert summary["done"] == 4 and summary["solved_now"] == 4
    return store


def _cli(*args, check=True):
    """The command with ``--json``, in this process (the kill and two-runs tests start real ones)."""
    res = CliRunner().invoke(app, [*args, "--json"])
    assert not check or res.exit_code == 0, res.output
    return res


def test_every_point_file_is_recorded_with_its_sha256_and_size(tmp_path):
    import hashlib

    store = _solved_store(tmp_path)
    index = pd.read_parquet(tmp_path / "h" / "index.parquet")
    for row in index.itertuples(index=False):
        data = store.result_path(row.point).read_bytes()
        assert row.sha256 == hashlib.sha256(data).hexdigest() and row.bytes == len(data)
        assert row.attempts == 1
    assert (tmp_path / "h" / "campaign.sha256").read_text().strip() == hashlib.sha256(
        (tmp_path / "h" / "campaign.json").read_bytes()
    ).hexdigest()
    before = {p: p.stat().st_mtime_ns for p in (tmp_path / "h").rglob("*")}
    (tmp_path / "h" / ".lock").unlink(missing_ok=True)
    assert load_campaign("h", runs_dir=tmp_path).n == 4  # a loader only reads (a read-only share)
    assert not (tmp_path / "h" / ".lock").exists()
    assert {p: p.stat().st_mtime_ns for p in (tmp_path / "h").rglob("*")} == {
        p: t for p, t in before.items() if p.name != ".lock"
    }


def test_truncated_point_file_is_named_by_status_and_loaders_and_solved_again_by_a_resume(tmp_path):
    run = ["campaign", "run", "--name", "tr", "--grid", GRID, "--mesh", "coarse", "--steps", "2"]
    run += ["--jobs", "1", "--runs-dir", str(tmp_path)]
    assert json.loads(_cli(*run).stdout)["done"] == 4
    path = tmp_path / "tr" / "points" / "00002.npz"
    size = path.stat().st_size
    os.truncate(path, 500)  # a full disk, a crashed file system, an interrupted copy
    status = json.loads(_cli("campaign", "status", "--name", "tr", "--runs-dir", str(tmp_path)).stdout)
    assert [(p["point"], p["file"]) for p in status["problems"]] == [(2, str(path))]
    assert f"500 bytes, {size} written" in status["problems"][0]["reason"]
    assert path.stat().st_size == 500  # status reports, repairs nothing
    # a loader names the file, in the JSON error contract (the command's own exit 1, no exception
    # escaping it), no traceback
    train = _cli("surrogate", "train", "--campaign", "tr", "--runs-dir", str(tmp_path), check=False)
    assert train.exit_code == 1 and isinstance(train.exception, SystemExit)
    assert "Traceback" not in train.stderr
    error = json.loads(train.stdout)["error"]
    assert str(path) in error and "500 bytes" in error and "campaign run" in error
    # the library's own reader names the file too (never a raw BadZipFile)
    with pytest.raises(ValueError, match=r"00002\.npz: not a readable simulation result, a truncated"):
        SimulationResult.load(path)
    check = json.loads(_cli(*run, "--verify-only").stdout)
    assert [p["point"] for p in check["problems"]] == [2] and check["solved_now"] == 0
    assert path.stat().st_size == 500  # --verify-only repairs nothing either
    again = json.loads(_cli(*run).stdout)
    assert again["solved_now"] == 1 and again["done"] == 4
    assert [p["point"] for p in again["problems"]] == [2]
    assert SimulationResult.load(path).force[-1] > 0
    assert len(list((tmp_path / "tr" / "damaged").iterdir())) == 1  # kept aside, never read again
    clean = json.loads(_cli("campaign", "status", "--name", "tr", "--runs-dir", str(tmp_path)).stdout)
    assert clean["problems"] == [] and clean["done"] == 4


def test_flipped_byte_inside_a_point_file_is_detected_and_solved_again(tmp_path):
    store = _solved_store(tmp_path)
    path = store.result_path(1)
    before = SimulationResult.load(path).force
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0x01  # one bit, size unchanged
    path.write_bytes(bytes(data))
    seen = CampaignStore.open(tmp_path / "h", repair=False)
    assert [(p.point, "content changed" in p.reason) for p in seen.problems] == [(1, True)]
    with pytest.raises(CampaignError, match=r"00001\.npz: content changed since written"):
        load_campaign("h", runs_dir=tmp_path)
    s = run_campaign(CampaignStore.open(tmp_path / "h"), jobs=1)
    assert s["solved_now"] == 1 and s["done"] == 4
    np.testing.assert_array_equal(SimulationResult.load(path).force, before)
    assert load_campaign("h", runs_dir=tmp_path).n == 4


def test_deleted_point_file_is_detected_and_solved_again(tmp_path):
    store = _solved_store(tmp_path)
    store.result_path(3).unlink()
    seen = CampaignStore.open(tmp_path / "h", repair=False)
    assert [(p.point, p.reason) for p in seen.problems] == [(3, "missing (the index says done)")]
    s = run_campaign(CampaignStore.open(tmp_path / "h"), jobs=1)
    assert s["solved_now"] == 1 and s["done"] == 4 and store.result_path(3).is_file()


def test_deleted_index_row_is_detected_and_rebuilt_from_the_point_file(tmp_path):
    _solved_store(tmp_path)
    path = tmp_path / "h" / "index.parquet"
    index = pd.read_parquet(path)
    sha = index.loc[2, "sha256"]
    index.drop(index=2).to_parquet(path, index=False)
    seen = CampaignStore.open(tmp_path / "h", repair=False)
    assert [p.point for p in seen.problems] == [2] and "no row for point 2" in seen.problems[0].reason
    s = run_campaign(CampaignStore.open(tmp_path / "h"), jobs=1)
    assert s["solved_now"] == 0 and s["done"] == 4  # the file was checked to load: nothing solved
    index = pd.read_parquet(path)
    assert sorted(index["point"]) == [0, 1, 2, 3] and index.loc[2, "sha256"] == sha
    assert str(index.loc[2, "status"]) == "done" and index.loc[2, "wall_s"] > 0
    # an index file that cannot be read at all is rebuilt from the point files the same way
    path.write_bytes(path.read_bytes()[:100])
    s = run_campaign(CampaignStore.open(tmp_path / "h"), jobs=1)
    assert s["solved_now"] == 0 and s["done"] == 4 and "unreadable" in s["problems"][0]["reason"]
    assert CampaignStore.open(tmp_path / "h", repair=False).problems == []


def test_an_older_store_gets_its_hashes_on_its_first_resume_after_each_file_loads(tmp_path):
    store = _solved_store(tmp_path)
    path = tmp_path / "h" / "index.parquet"
    old = pd.read_parquet(path).drop(columns=["sha256", "bytes", "attempts", "flagged_steps", "rerun_s"])
    old.to_parquet(path, index=False)
    (tmp_path / "h" / "campaign.sha256").unlink()
    store.result_path(0).write_bytes(store.result_path(0).read_bytes()[:300])  # one damaged file
    seen = CampaignStore.open(tmp_path / "h", repair=False)  # status: loads each file, reports
    assert [p.point for p in seen.problems] == [0] and "unreadable" in seen.problems[0].reason
    resumed = CampaignStore.open(tmp_path / "h")
    assert sorted(resumed.hashed_now) == [1, 2, 3] and (tmp_path / "h" / "campaign.sha256").is_file()
    s = run_campaign(resumed, jobs=1)
    assert s["solved_now"] == 1 and s["done"] == 4
    assert pd.read_parquet(path)["sha256"].notna().all()


def test_a_changed_campaign_json_is_named(tmp_path):
    _solved_store(tmp_path)
    meta = tmp_path / "h" / "campaign.json"
    text = meta.read_text()
    assert "    150.0\n" in text
    meta.write_text(text.replace("    150.0\n", "    151.0\n", 1))  # still JSON, another design
    with pytest.raises(CampaignError, match=r"campaign\.json: changed since the campaign was created"):
        CampaignStore.open(tmp_path / "h")
    meta.write_text("{")
    with pytest.raises(CampaignError, match=r"campaign\.json: unreadable campaign spec"):
        CampaignStore.open(tmp_path / "h")


def test_a_full_disk_is_a_clear_error_and_nothing_is_written_half(tmp_path, monkeypatch):
    import errno

    from indentation_studio.campaign.errors import DiskFullError

    store = CampaignStore.create_or_open(tmp_path, _spec("full", GRID))
    calls = {"n": 0}
    original = np.savez_compressed

    def savez(fh, **arrays):  # the second point's file: the disk fills half-way through it
        calls["n"] += 1
        if calls["n"] == 2:
            fh.write(b"PK\x03\x04 half a file")
            raise OSError(errno.ENOSPC, "No space left on device")
        return original(fh, **arrays)

    monkeypatch.setattr(np, "savez_compressed", savez)
    with pytest.raises(
        DiskFullError, match=r"disk full while writing .*00001\.npz: nothing was written half"
    ):
        run_campaign(store, jobs=1)
    monkeypatch.setattr(np, "savez_compressed", original)
    files = sorted(p.name for p in store.points_dir.iterdir())
    assert files == ["00000.npz"]  # no temporary file, no half file
    s = run_campaign(CampaignStore.open(tmp_path / "full"), jobs=1)
    assert s["done"] == 4 and s["solved_now"] == 3 and s["problems"] == []


def test_two_runs_started_together_solve_each_point_once(tmp_path):
    args = [*CLI, "campaign", "run", "--name", "two", "--grid", "c1=3:15:3,c5=100:500:3", "--mesh", "coarse"]
    args += ["--steps", "2", "--jobs", "1", "--runs-dir", str(tmp_path), "--json"]
    procs = [
        subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for _ in range(2)
    ]
    outs = [p.communicate(timeout=600) for p in procs]
    assert all(p.returncode == 0 for p in procs), [o[1][-2000:] for o in outs]
    summaries = [json.loads(o[0]) for o in outs]
    assert all(s["done"] == 9 and s["pending"] == 0 for s in summaries)
    assert sum(s["solved_now"] for s in summaries) == 9  # once in total
    index = pd.read_parquet(tmp_path / "two" / "index.parquet")
    assert index["attempts"].tolist() == [1] * 9 and set(index["status"].astype(str)) == {"done"}
    assert list((tmp_path / "two" / "leases").iterdir()) == []


def test_claims_held_by_a_live_run_are_skipped_and_named_and_a_dead_ones_taken_over(tmp_path):
    from indentation_studio.campaign.leases import RunIdentity

    store = CampaignStore.create_or_open(tmp_path, _spec("cl", GRID))
    other = RunIdentity("elsewhere01", "node17.cluster", 4242, time.time() - 60)
    dead = RunIdentity("deadrun0001", socket_host(), _dead_pid(), time.time() - 60)
    store.leases_dir.mkdir(exist_ok=True)
    (store.lease_path(0)).write_text(json.dumps(other.lease(0)))  # a live run on another machine
    (store.lease_path(1)).write_text(json.dumps(dead.lease(1)))  # a run killed on this machine
    stale = other.lease(2) | {"heartbeat": time.time() - 3600}  # not renewed for an hour
    (store.lease_path(2)).write_text(json.dumps(stale))
    res = _cli("campaign", "status", "--name", "cl", "--runs-dir", str(tmp_path))
    claims = {c["point"]: c for c in json.loads(res.stdout)["claims"]}
    assert claims[0]["host"] == "node17.cluster" and claims[0]["pid"] == 4242 and claims[0]["alive"]
    assert not claims[1]["alive"] and not claims[2]["alive"]
    s = run_campaign(CampaignStore.open(tmp_path / "cl"), jobs=1, wait_for_held=False)
    assert s["solved_now"] == 3 and s["done"] == 3 and s["pending"] == 1  # 1 and 2 taken over
    assert s["held_by_other_runs"] == [{"point": 0, "host": "node17.cluster", "pid": 4242}]
    text = CliRunner().invoke(app, ["campaign", "status", "--name", "cl", "--runs-dir", str(tmp_path)]).stdout
    assert "point 0 held by node17.cluster pid 4242" in text and "running" in text
    # the other run dies (its heartbeat stops): a run waiting for the point takes it over
    (store.lease_path(0)).write_text(json.dumps(other.lease(0) | {"heartbeat": time.time() - 2}))
    s = run_campaign(CampaignStore.open(tmp_path / "cl"), jobs=1, lease_timeout_s=3.0, poll_s=0.2)
    assert s["solved_now"] == 1 and s["done"] == 4 and s["held_by_other_runs"] == []


def socket_host() -> str:
    import socket

    return socket.gethostname()


def _dead_pid() -> int:
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


@pytest.mark.slow
def test_dask_worker_killed_mid_campaign_loses_only_its_point(tmp_path):
    """A real scheduler and worker on 127.0.0.1; the worker is SIGKILLed while it solves, a new
    one is started: every point done, each written once and whole."""
    pytest.importorskip("distributed")
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    bin_dir = os.path.dirname(sys.executable)
    log = open(tmp_path / "dask.log", "wb")
    procs = []

    def start(*args):
        p = subprocess.Popen(
            [os.path.join(bin_dir, "dask"), *args],
            stdout=log,
            stderr=log,
            cwd=tmp_path,
            start_new_session=True,
        )
        procs.append(p)
        return p

    def worker():
        return start(
            "worker", address, "--nthreads", "1", "--no-nanny", "--host", "127.0.0.1", "--no-dashboard"
        )

    try:
        start("scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard")
        first = worker()
        args = [
            *CLI,
            "campaign",
            "run",
            "--name",
            "dk",
            "--grid",
            "c1=3:15:4,c5=100:500:2",
            "--mesh",
            "coarse",
        ]
        args += ["--steps", "4", "--scheduler", address, "--runs-dir", str(tmp_path), "--json"]
        run = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        points = tmp_path / "dk" / "points"
        deadline = time.time() + 240
        while time.time() < deadline and len(list(points.glob("[0-9]*.npz"))) < 2 and run.poll() is None:
            time.sleep(0.05)
        time.sleep(0.3)  # into the next point
        first.send_signal(signal.SIGKILL)
        first.wait(timeout=30)
        killed_at = len(list(points.glob("[0-9]*.npz")))
        assert 2 <= killed_at < 8, "the kill must land part way"
        worker()
        out, err = run.communicate(timeout=400)
        assert run.returncode == 0, err[-3000:]
        summary = json.loads(out)
        assert summary["done"] + summary["failed"] == 8 and summary["pending"] == 0
        if summary["failed"]:  # recorded with its reason, never lost
            assert all("worker lost" in f["error"] for f in summary["failures"])
        index = pd.read_parquet(tmp_path / "dk" / "index.parquet")
        assert index["attempts"].tolist() == [1] * 8  # each point recorded (written) once
        files = sorted(p.name for p in points.iterdir())
        assert files == [f"{i:05d}.npz" for i in index.loc[index.status == "done", "point"]]
        assert CampaignStore.open(tmp_path / "dk", repair=False).problems == []  # whole files
        for i in index.loc[index.status == "done", "point"]:
            assert SimulationResult.load(points / f"{i:05d}.npz").force[-1] > 0
    finally:
        for p in procs:
            if p.poll() is None:
                p.send_signal(signal.SIGKILL)
                p.wait(timeout=30)
        log.close()


def test_damaged_experiment_surrogate_and_budget_files_are_named_in_the_json_error_contract(tmp_path):
    """Every loader names the file and what is wrong with it (``{"error": ...}``, exit 1), never a
    traceback: a truncated DIC file of an experiment, a truncated surrogate file, an error budget
    that is not one."""
    import shutil

    exp = tmp_path / "exp"
    shutil.copytree(os.path.join(os.path.dirname(__file__), "..", "examples", "synthetic-12-250"), exp)
    (exp / "dic.npz").write_bytes((exp / "dic.npz").read_bytes()[:700])
    res = CliRunner().invoke(app, ["check", "--experiment", str(exp), "--mesh", "coarse", "--json"])
    assert res.exit_code == 1 and "Traceback" not in res.output
    error = json.loads(res.stdout.strip().splitlines()[-1])["error"]
    assert str(exp / "dic.npz") in error and "not a readable DIC file, truncated or damaged" in error
    model = tmp_path / "cut.safetensors"
    model.write_bytes(b"\x10\x00\x00\x00\x00\x00\x00\x00{}")
    whole = tmp_path / "whole"
    shutil.copytree(os.path.join(os.path.dirname(__file__), "..", "examples", "synthetic-12-250"), whole)
    res = CliRunner().invoke(app, ["fit", "--experiment", str(whole), "--surrogate", str(model), "--json"])
    assert res.exit_code == 1 and "Traceback" not in res.output
    assert str(model) in json.loads(res.stdout.strip().splitlines()[-1])["error"]
    from indentation_studio.surrogate.error_budgets import remaining_bias

    budget = tmp_path / "error-budget.json"
    budget.write_text(json.dumps({"rows": [{"model": "coarse", "c1_bias_pct": "x"}]}))
    with pytest.raises(ValueError, match=r"error-budget\.json: 'coarse' has no numeric c1_bias_pct"):
        remaining_bias(budget, "coarse")
