"""The CLI contract: --json prints exactly one JSON object on stdout; bad input is a named error."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from indentation_studio.forward.mesh_study import nodes_on_sphere
from indentation_studio.forward.result import SimulationResult
from indentation_studio.studio.cli import app

runner = CliRunner()


def test_simulate_json_contract(tmp_path):
    out = tmp_path / "r.npz"
    res = runner.invoke(app, ["simulate", "--mesh", "coarse", "--steps", "2", "--out", str(out), "--json"])
    assert res.exit_code == 0, res.output
    payload = json.loads(res.stdout)
    for key in ("depth_mm", "force_mN", "wall_s", "newton_iterations", "result_file"):
        assert key in payload
    assert payload["depth_mm"] == [0.0, 0.5, 1.0]
    saved = SimulationResult.load(payload["result_file"])
    assert np.allclose(saved.force, payload["force_mN"])
    assert saved.spec["mesh"]["preset"] == "coarse"
    assert payload["force_mN"][2] > payload["force_mN"][1] > 0


def test_simulate_bad_modulus_is_named():
    res = runner.invoke(app, ["simulate", "--c5", "nan", "--json"])
    assert res.exit_code == 1
    assert "material.c5" in json.loads(res.stdout)["error"]


def test_simulate_missing_feb_is_named(tmp_path):
    res = runner.invoke(app, ["simulate", "--mesh-from", str(tmp_path / "none.feb"), "--json"])
    assert res.exit_code == 1
    assert "none.feb" in json.loads(res.stdout)["error"]


def test_mesh_study_json_rows_and_reuse_of_saved_results(tmp_path):
    args = ["mesh-study", "--presets", "coarse", "--reference", "default", "--steps", "2"]
    res = runner.invoke(app, [*args, "--out-dir", str(tmp_path), "--json"])
    assert res.exit_code == 0, res.output
    rows = json.loads(res.stdout)["rows"]
    assert [r["preset"] for r in rows] == ["coarse"]
    assert rows[0]["nodes"] == 576
    assert 0.0 < rows[0]["E_u_pct"] < 50.0
    assert rows[0]["E_f_rel_pct"] == rows[0]["E_f_pct"] * 2  # eq. 1a divides by N_s = 2
    # eq. 1b's contact-surface reading: the nodes on the sphere are the ones the solver attached
    coarse = SimulationResult.load(tmp_path / "coarse.npz")
    assert (
        rows[0]["contact_nodes"]
        == nodes_on_sphere(coarse).sum()
        == coarse.convergence["attached_nodes"][-1]
        > 0
    )
    assert 0.0 <= rows[0]["E_u_contact_pct"] < rows[0]["E_u_pct"]
    # the same study again reads both meshes back and prints the same figures
    again = runner.invoke(app, [*args, "--out-dir", str(tmp_path), "--json"])
    assert again.exit_code == 0 and json.loads(again.stdout)["rows"] == rows
    assert "read" in again.stderr and str(tmp_path / "default.npz") in again.stderr.replace("\n", "")
    # another material is another spec: solved, not read
    other = runner.invoke(app, [*args, "--c1", "5", "--out-dir", str(tmp_path), "--json"])
    assert other.exit_code == 0 and "read" not in other.stderr


def test_simulate_vtu_series_for_paraview(tmp_path):
    import meshio

    res = CliRunner().invoke(
        app,
        [
            *("simulate", "--mesh", "coarse", "--steps", "2", "--out", str(tmp_path / "r.npz")),
            *("--vtu", str(tmp_path / "vtu"), "--json"),
        ],
    )
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    pvd = (tmp_path / "vtu" / "step.pvd").read_text()
    assert out["vtu_series"].endswith("step.pvd") and pvd.count("<DataSet") == 3
    m = meshio.read(tmp_path / "vtu" / "step_002.vtu")
    u = m.point_data["displacement"]
    assert m.cells_dict["hexahedron"].shape[1] == 8 and u[:, 2].min() == pytest.approx(-1.0, abs=1e-6)
