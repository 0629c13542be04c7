"""FEBio backend: log parser vs the stored arrays, writer vs the .feb real FEBio ran, runner errors."""

from __future__ import annotations

import json
import os
import stat
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from conftest import FEBIO_FEB as FEB
from conftest import FEBIO_LOG as LOG
from conftest import FEBIO_NPZ as NPZ
from typer.testing import CliRunner

from indentation_studio.forward.contact_quadrature import top_faces
from indentation_studio.forward.febio.log import febio_result, read_febio_log
from indentation_studio.forward.febio.runner import (
    FebioError,
    FebioNotFoundError,
    FebioSolver,
    find_febio,
)
from indentation_studio.forward.febio.writer import indenter_surface, write_feb
from indentation_studio.forward.mesh import preset_mesh
from indentation_studio.forward.spec import MeshChoice, ModelSpec
from indentation_studio.studio.cli import app

pytestmark = pytest.mark.skipif(not FEB.is_file(), reason="../shared/febio/baseline not beside the clone")


def baseline_spec() -> ModelSpec:
    return ModelSpec(mesh=MeshChoice(feb_file=str(FEB)))


def test_parse_baseline_log_gives_the_stored_arrays():
    ref = np.load(NPZ)
    log = read_febio_log(LOG)
    assert log.terminated == "normal" and log.version.startswith("4.")
    r = febio_result(log, baseline_spec().to_dict(), feb_file=FEB, steps=28)
    np.testing.assert_array_equal(r.depth, ref["depth"])
    # 12.5 mm (step 25) is off equilibrium (tests/test_febio_equilibrium.py): NaN, the rest as stored
    clean = np.arange(29) != 25
    assert np.isnan(r.force[25]) and r.off_equilibrium_depths == [12.5]
    np.testing.assert_array_equal(r.force[clean], ref["F_full"][clean])
    np.testing.assert_array_equal(r.force_quarter[clean], ref["F_quarter"][clean])
    np.testing.assert_array_equal(r.convergence["indenter_reaction_quarter"], ref["F_quarter"])
    np.testing.assert_array_equal(r.top_node_ids, ref["top_ids"])
    np.testing.assert_array_equal(r.displacement, ref["U_top"])
    np.testing.assert_allclose(r.top_xyz, ref["top_xyz0"], atol=1e-8)
    np.testing.assert_array_equal(r.convergence["bottom_reaction_quarter"], ref["Rz_bottom_sum"])
    assert r.solver["name"] == "febio" and r.solver["version"] == log.version
    assert r.solver["feb_file"] == str(FEB)


def _number(text: str):
    try:
        return tuple(round(float(v), 6) for v in text.split(","))
    except ValueError:
        return text.strip()


def _canon(el: ET.Element, skip_attrib=("file",)) -> tuple:
    """An XML element as a comparable tree: tag, attributes, numeric text, children in order."""
    attrib = tuple(sorted((k, _number(v)) for k, v in el.attrib.items() if k not in skip_attrib))
    text = _number(el.text) if el.text and el.text.strip() else None
    return (el.tag, attrib, text, tuple(_canon(c) for c in el if isinstance(c.tag, str)))


def _by_id(section: ET.Element, path: str) -> dict[int, tuple]:
    return {int(e.attrib["id"]): _number(e.text) for e in section.iterfind(path)}


@pytest.fixture(scope="module")
def written(tmp_path_factory) -> tuple[ET.Element, ET.Element]:
    path = write_feb(baseline_spec(), tmp_path_factory.mktemp("feb") / "baseline.feb")
    return ET.parse(path).getroot(), ET.parse(FEB).getroot()


def test_writer_nodes_and_elements_match_febio_baseline(written):
    ours, ref = written
    for name in ("BlockNodes", "IndenterNodes"):
        a = _by_id(ours, f"Mesh/Nodes[@name='{name}']/node")
        b = _by_id(ref, f"Mesh/Nodes[@name='{name}']/node")
        assert a.keys() == b.keys()
        np.testing.assert_allclose([a[i] for i in a], [b[i] for i in a], atol=1e-8)
    assert len(_by_id(ours, "Mesh/Nodes[@name='IndenterNodes']/node")) == 169
    for name in ("Block", "Indenter"):
        a = _by_id(ours, f"Mesh/Elements[@name='{name}']/elem")
        assert a == _by_id(ref, f"Mesh/Elements[@name='{name}']/elem") and len(a) in (1100, 288)
    for tag in ("NodeSet", "Surface", "SurfacePair"):
        assert [_canon(e) for e in ours.iterfind(f"Mesh/{tag}")] == [
            _canon(e) for e in ref.iterfind(f"Mesh/{tag}")
        ]


@pytest.mark.parametrize(
    "section", ["Module", "Control", "Material", "MeshDomains", "Boundary", "Rigid", "Contact", "LoadData"]
)
def test_writer_sections_match_febio_baseline(written, section):
    ours, ref = written
    assert _canon(ours.find(section)) == _canon(ref.find(section))


def test_writer_material_and_contact_values(written):
    ours, _ = written
    block = ours.find("Material/material[@type='trans iso Mooney-Rivlin']")
    values = {c.tag: c.text for c in block if c.tag != "fiber"}
    assert float(values["c1"]) == 10 and float(values["c5"]) == 350 and float(values["k"]) == 1000
    assert float(values["c2"]) == 0 and float(values["c3"]) == 1e-9 and float(values["lam_max"]) == 1
    contact = ours.find("Contact/contact")
    assert contact.attrib["type"] == "sliding-elastic" and float(contact.find("fric_coeff").text) == 1e8
    assert float(contact.find("penalty").text) == 100 and contact.find("auto_penalty").text == "1"
    assert float(ours.find("Rigid/rigid_bc[@type='rigid_displacement']/value").text) == -14


def test_writer_output_requests_match(written):
    ours, ref = written
    assert _canon(ours.find("Output")) == _canon(ref.find("Output"))  # all but the log's file name
    assert ours.find("Output/logfile").attrib["file"] == "baseline.log"


def test_indenter_surface_on_sphere_with_outward_normals():
    center = np.array([0.0, 0.0, 68.0])
    xyz, tri = indenter_surface(8.0, center, 6)
    np.testing.assert_allclose(np.linalg.norm(xyz - center, axis=1), 8.0, rtol=1e-12)
    assert len(xyz) == 28 + 21 and len(tri) == 2 * 36
    a, b, c = (xyz[tri[:, i]] for i in range(3))
    normal = np.cross(b - a, c - a)
    assert np.all(np.einsum("ij,ij->i", normal, (a + b + c) / 3 - center) > 0)


def test_top_faces_cover_the_top_with_upward_normals():
    mesh = preset_mesh("coarse")
    faces = top_faces(mesh, upward=True)
    x = mesh.nodes[faces]
    area = 0.5 * np.linalg.norm(np.cross(x[:, 2] - x[:, 0], x[:, 3] - x[:, 1]), axis=1)
    assert area.sum() == pytest.approx(50.0 * 50.0, rel=1e-12)
    assert np.all(np.cross(x[:, 1] - x[:, 0], x[:, 3] - x[:, 0])[:, 2] > 0)
    # the same faces as the surface contact's, each only turned
    assert {frozenset(f) for f in top_faces(mesh)} == {frozenset(f) for f in faces}


def test_no_febio_names_febio_path(monkeypatch, tmp_path):
    with pytest.raises(FebioNotFoundError, match="FEBIO_PATH"):
        find_febio({"PATH": str(tmp_path)})
    with pytest.raises(FebioNotFoundError, match="FEBIO_PATH=/nowhere"):
        find_febio({"FEBIO_PATH": "/nowhere", "PATH": str(tmp_path)})
    monkeypatch.setenv("PATH", str(tmp_path))
    monkeypatch.delenv("FEBIO_PATH", raising=False)
    res = CliRunner().invoke(app, ["simulate", "--solver", "febio", "--mesh", "coarse", "--json"])
    assert res.exit_code == 1
    out = json.loads(res.stdout)
    assert "FEBIO_PATH" in out["error"] and "\n" not in out["error"]


def _fake_febio(folder: Path, log_text: str, exit_code: int) -> Path:
    """An executable that, like febio4 -i model.feb, writes model.log beside the input."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "fake.log").write_text(log_text, encoding="latin-1")
    exe = folder / "febio4"
    exe.write_text(
        f"#!{sys.executable}\n"
        "import pathlib, shutil, sys\n"
        "feb = pathlib.Path(sys.argv[sys.argv.index('-i') + 1])\n"
        f"shutil.copy({str(folder / 'fake.log')!r}, feb.with_suffix('.log'))\n"
        f"sys.exit({exit_code})\n"
    )
    exe.chmod(exe.stat().st_mode | stat.S_IXUSR)
    return exe


def test_fake_febio_error_termination_names_depth_reached(tmp_path):
    text = LOG.read_text(encoding="latin-1")
    cut = text.index("------- converged at time : 6.96")  # last records kept: time 6 = 3 mm
    exe = _fake_febio(tmp_path / "bin", text[:cut] + "\n E R R O R   T E R M I N A T I O N\n", 1)
    assert find_febio({"FEBIO_PATH": str(tmp_path / "bin")}) == exe
    with pytest.raises(FebioError, match=r"depth 3\.000 mm of 14 mm") as info:
        FebioSolver(baseline_spec(), executable=exe, workdir=tmp_path / "run").run()
    assert info.value.depth_reached == pytest.approx(3.0)
    assert "E R R O R   T E R M I N A T I O N" in str(info.value)  # quotes the log's last lines
    partial = info.value.partial
    np.testing.assert_allclose(partial.force, np.load(NPZ)["F_full"][:7])


def test_fake_febio_normal_run_reads_back_the_result(tmp_path):
    exe = _fake_febio(tmp_path / "bin", LOG.read_text(encoding="latin-1"), 0)
    r = FebioSolver(baseline_spec(), executable=exe, workdir=tmp_path / "run").run()
    clean = np.arange(29) != 25  # 12.5 mm: off equilibrium in FEBio's run, and in its rerun here
    np.testing.assert_array_equal(r.force[clean], np.load(NPZ)["F_full"][clean])
    assert np.isnan(r.force[25]) and r.solver["rerun"]["kept"] == "first"
    assert (tmp_path / "run" / "model.feb").is_file() and r.solver["executable"] == str(exe)
    assert (tmp_path / "run" / "rerun" / "model.log").is_file()


def test_cli_export_feb_and_febio_simulate(tmp_path, monkeypatch):
    res = CliRunner().invoke(
        app, ["export-feb", "--mesh-from", str(FEB), "--out", str(tmp_path / "m.feb"), "--json"]
    )
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["feb_file"] == str(tmp_path / "m.feb")
    assert ET.parse(tmp_path / "m.feb").getroot().find("Output/logfile").attrib["file"] == "m.log"
    _fake_febio(tmp_path / "bin", LOG.read_text(encoding="latin-1"), 0)
    monkeypatch.setenv("FEBIO_PATH", str(tmp_path / "bin"))
    out = tmp_path / "r.npz"
    res = CliRunner().invoke(
        app, ["simulate", "--solver", "febio", "--mesh-from", str(FEB), "--out", str(out), "--json"]
    )
    assert res.exit_code == 0, res.output
    payload = json.loads(res.stdout)
    assert payload["force_mN"][-1] == pytest.approx(float(np.load(NPZ)["F_full"][-1]))
    assert payload["force_mN"][25] is None and payload["off_equilibrium_depths_mm"] == [12.5]
    assert os.path.isfile(payload["result_file"])
