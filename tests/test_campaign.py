"""Campaigns: designs, the resumable store, kill and resume, failures, dask, the loader."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from indentation_studio.campaign.designs import (
    DesignError,
    design_from_option,
    paper_grid,
    parse_grid,
    points_from_csv,
    space_filling,
)
from indentation_studio.campaign.loader import force_table, load_campaign
from indentation_studio.campaign.runner import run_campaign
from indentation_studio.campaign.store import CampaignError, CampaignSpec, CampaignStore
from indentation_studio.forward.result import SimulationResult
from indentation_studio.forward.solver import EmbeddedSolver, SimulationError, simulate
from indentation_studio.forward.spec import MeshChoice, ModelSpec, Protocol

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
    monkeypatch.setattr(EmbeddedSolver, "run", original)
    again = run_campaign(CampaignStore.open(tmp_path / "f"), jobs=1)
    assert again["solved_now"] == 0  # failed points wait for --retry-failed
    again = run_campaign(CampaignStore.open(tmp_path / "f"), jobs=1, retry_failed=True)
    assert (again["done"], again["failed"], again["solved_now"]) == (3, 1, 2)


def test_timeout_fails_points_and_retry_recovers(tmp_path):
    store = CampaignStore.create_or_open(tmp_path, _spec("t", "c1=5:10:2,c5=200:200:1"))
    s = run_campaign(store, jobs=2, timeout_s=1e-6)
    assert s["failed"] == 2 and all("timeout" in f["error"] for f in s["failures"])
    s = run_campaign(CampaignStore.open(tmp_path / "t"), jobs=2, retry_failed=True)
    assert s["done"] == 2 and s["failed"] == 0


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
