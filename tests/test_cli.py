"""The CLI contract: --json prints exactly one JSON object on stdout; bad input is a named error."""

import json

import numpy as np
import pytest
from rich.console import Console
from typer.testing import CliRunner

from indentation_studio.forward.convergence.mesh_study import nodes_on_sphere
from indentation_studio.forward.result import SimulationResult
from indentation_studio.studio import campaign_cli, progress
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


def test_model_options_give_a_command_its_flags_and_one_object():
    """@model_options puts the named flags where `model` stands (defaults given or the paper's),
    fixes the fields without a flag, and hands the command one ModelOptions."""
    from typing import Annotated

    import typer

    from indentation_studio.studio.options import REQUIRED, ModelOptions, model_options, option_group

    seen = {}
    mini = typer.Typer()

    @mini.command()
    @model_options("c1", "radius", "friction", c1=3.0, substeps=2)
    def show(name: str = "x", *, model: ModelOptions, as_json: bool = False) -> None:
        seen["model"], seen["name"] = model, name

    res = runner.invoke(mini, ["--radius", "8", "--friction", "0.3", "--name", "y"])
    assert res.exit_code == 0, res.output
    assert seen["name"] == "y"
    assert seen["model"] == ModelOptions(c1=3.0, radius=8.0, friction=0.3, substeps=2)
    spec = seen["model"].spec()
    assert (spec.material.c1, spec.indenter.radius, spec.contact.friction) == (3.0, 8.0, 0.3)
    assert spec.solver.substeps == 2
    assert "--c5" not in runner.invoke(mini, ["--help"]).output  # only the flags named

    kappa_flag = Annotated[float, typer.Option(help="kappa, kPa")]

    @mini.command()
    @option_group(ModelOptions, {"kappa": kappa_flag}, "model", ("kappa",), {"kappa": REQUIRED})
    def needs(*, model: ModelOptions) -> None:
        seen["kappa"] = model.kappa

    assert runner.invoke(mini, ["needs"]).exit_code == 2  # a required flag missing: click's usage error
    assert runner.invoke(mini, ["needs", "--kappa", "500"]).exit_code == 0 and seen["kappa"] == 500


def test_default_result_file_names_material_radius_contact_mesh_and_solver():
    from indentation_studio.forward.simulation_run import default_result_file
    from indentation_studio.studio.options import ModelOptions

    spec = ModelOptions(c1=9.4, radius=8, mesh="coarse", friction=0.3).spec()
    assert (
        str(default_result_file(spec, "febio"))
        == "runs/simulations/c1=9.4_c5=350_R=8_mu=0.3_coarse_febio.npz"
    )
    assert default_result_file(ModelOptions().spec()).name == "c1=10_c5=350_R=4.77_default_embedded.npz"
    surface = ModelOptions(contact="surface", contact_order=1, contact_penalty=1e6).spec()
    assert (surface.contact.integration, surface.contact.order, surface.contact.penalty) == (
        "surface",
        1,
        1e6,
    )
    assert (
        default_result_file(surface).name == "c1=10_c5=350_R=4.77_surface1_penalty=1e+06_default_embedded.npz"
    )
    # the default penalty is not named (files written before the flag keep their names)
    assert "penalty" not in default_result_file(ModelOptions(contact="surface").spec()).name


def test_the_command_lines_registration_default_is_the_librarys():
    from indentation_studio.inference.experiment.processing_error import REGISTRATION_MM
    from indentation_studio.studio.inference_cli import REGISTRATION_DEFAULT_MM

    assert REGISTRATION_DEFAULT_MM == REGISTRATION_MM == 0.1


def test_the_time_left_of_a_resumed_run_is_the_rate_of_its_own_steps(monkeypatch):
    # resumed after step 17 of 28: 18 at 100 s, 19 at 200 s -> 9 steps left at 100 s each
    clock = iter([0.0, 100.0, 200.0])
    monkeypatch.setattr(progress.time, "perf_counter", lambda: next(clock))
    console = Console(record=True, width=200, force_terminal=False)
    with progress.step_progress(console, "simulate", 28) as bar:
        bar.update(18)
        bar.update(19)
    lines = console.export_text().splitlines()
    assert lines[0].endswith("elapsed 100.0 s, eta 1000.0 s") and lines[1].endswith(
        "elapsed 200.0 s, eta 900.0 s"
    )


def test_a_campaign_of_long_points_reports_minutes_a_point(monkeypatch):
    """A level-3 friction campaign's log said "0.0 points/min" after a point of 1,629 s."""
    clock = iter([0.0, 1629.2, 60.0])
    monkeypatch.setattr(campaign_cli.time, "perf_counter", lambda: next(clock))
    said = []

    class Bar:
        def update(self, completed, info="", total=None):
            said.append(info)

    report = campaign_cli._points_progress(Bar())
    report(1, 13, {"done": 3, "failed": 1})
    assert said[-1] == "done 3 failed 1  27.2 min a point"
    report(10, 13, {"done": 12, "failed": 1})
    assert said[-1] == "done 12 failed 1  10.0 points/min"
