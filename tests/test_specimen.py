"""The specimen's size as a model parameter (issue 59): the CLI's ``--specimen`` reaches the spec,
every mesh preset family that takes a geometry (graded blocks, the contact family), the FEBio
export and the spec stored in a result; the paper's block stays the default."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest
from typer.testing import CliRunner

from indentation_studio.forward.mesh import build_mesh
from indentation_studio.forward.spec import Geometry, SpecError
from indentation_studio.studio.cli import app
from indentation_studio.studio.options import ModelOptions, specimen_geometry


def test_the_specimen_is_width_depth_thickness_and_the_paper_block_by_default():
    assert specimen_geometry("60x60x30") == Geometry(half_x=30.0, half_y=30.0, height=30.0)
    assert specimen_geometry("80 x 50 x 20") == Geometry(half_x=40.0, half_y=25.0, height=20.0)
    assert ModelOptions().spec().geometry == Geometry(50.0, 50.0, 60.0)
    for bad in ("60x60", "60x60x-3", "axbxc", "60x60x30x1"):
        with pytest.raises(SpecError, match=r"specimen|geometry"):
            specimen_geometry(bad)


@pytest.mark.parametrize(("mesh", "size"), [("coarse", "60x40x30"), ("contact-L0", "60x60x30")])
def test_the_specimen_reaches_the_mesh(mesh, size):
    spec = ModelOptions(mesh=mesh, radius=6.0, specimen=size).spec()
    xyz = build_mesh(spec).nodes
    half = [float(v) / 2 for v in size.split("x")[:2]]
    np.testing.assert_allclose(xyz.min(axis=0), [0.0, 0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(xyz.max(axis=0), [*half, 30.0], rtol=1e-12)


def test_a_specimen_too_small_for_the_contact_family_is_refused_by_name():
    spec = ModelOptions(mesh="contact-L0", radius=6.0, specimen="60x40x30").spec()
    with pytest.raises(ValueError, match=r"core of 10 mm.*too little to grow into over 20 mm"):
        build_mesh(spec)


def test_the_specimen_reaches_the_febio_file(tmp_path):
    out = tmp_path / "small.feb"
    result = CliRunner().invoke(
        app, ["export-feb", "--out", str(out), "--mesh", "coarse", "--steps", "2", "--specimen", "60x60x30"]
    )
    assert result.exit_code == 0, result.output
    nodes = np.array(
        [[float(v) for v in n.text.split(",")] for n in ET.parse(out).getroot().iter("node")], float
    )
    block = nodes[nodes[:, 2] <= 30.0 + 1e-9]  # the indenter's own nodes (rigid sphere) sit above
    np.testing.assert_allclose(block.max(axis=0), [30.0, 30.0, 30.0], rtol=1e-9)
    bad = CliRunner().invoke(app, ["export-feb", "--out", str(out), "--specimen", "60x60"])
    assert bad.exit_code != 0 and "WIDTHxDEPTHxTHICKNESS" in bad.output


def test_an_experiments_specimen_is_read_and_picks_its_test(tmp_path):
    import json
    import shutil
    from pathlib import Path

    from indentation_studio.inference.experiment.data import ExperimentDataError, load_experiment
    from indentation_studio.surrogate.shipped import find_test

    example = Path(__file__).resolve().parents[1] / "examples" / "synthetic-12-250"
    folder = shutil.copytree(example, tmp_path / "exp")
    meta = json.loads((folder / "experiment.json").read_text())
    exp = load_experiment(folder)
    assert exp.specimen_mm is None and exp.block is None  # unsaid: the test is the indenter and protocol
    found = find_test(exp.radius, exp.depths, block=exp.block)
    assert found is not None and found.name == "paper-test-R4.77"
    (folder / "experiment.json").write_text(
        json.dumps(meta | {"specimen_mm": {"width": 100, "depth": 100, "thickness": 60}})
    )
    paper = load_experiment(folder)
    assert paper.block == {"half_x": 50.0, "half_y": 50.0, "height": 60.0}
    assert find_test(paper.radius, paper.depths, block=paper.block).name == "paper-test-R4.77"
    (folder / "experiment.json").write_text(
        json.dumps(meta | {"specimen_mm": {"width": 60, "depth": 60, "thickness": 30}})
    )
    small = load_experiment(folder)
    assert (
        find_test(small.radius, small.depths, block=small.block) is None
    )  # no shipped test of that specimen
    (folder / "experiment.json").write_text(
        json.dumps(meta | {"specimen_mm": {"width": 60, "depth": -1, "thickness": 30}})
    )
    with pytest.raises(ExperimentDataError, match=r"experiment\.json: specimen_mm .* positive"):
        load_experiment(folder)
