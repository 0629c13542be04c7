"""The shipped surrogates (issue 46): listed by a manifest, checked against their sha256 before they
are read, picked by a fit for the experiment's test and refused for any other test."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from indentation_studio.forward.fe_predictor import FESolverPredictor
from indentation_studio.forward.spec import ModelSpec
from indentation_studio.inference.experiment.synthetic import write_synthetic_experiment
from indentation_studio.inference.fit.inputs import prepare_fit
from indentation_studio.studio.cli import app
from indentation_studio.surrogate import shipped
from indentation_studio.surrogate.persistence import save_surrogate
from indentation_studio.surrogate.safe_file import SurrogateFileError

TRUTH = np.array([9.0, 330.0, 0.35])


def _entry(path, radius, depths):
    return {
        "name": path.stem,
        "file": path.name,
        "sha256": shipped.file_sha256(path),
        "bytes": path.stat().st_size,
        "test": {"radius_mm": radius, "depths_mm": list(depths)},
        "recipe": f"python tools/ship_surrogates.py --radius {radius:g}",
    }


@pytest.fixture(scope="module")
def shipped_folder(mu_surrogate, tmp_path_factory):
    """A folder shipping the coarse (c1, c5, mu) surrogate for its test: R = 4.77 mm, 3 x 0.5 mm."""
    folder = tmp_path_factory.mktemp("shipped")
    path = save_surrogate(mu_surrogate, folder / "test-R4.77-3x0.5.safetensors")
    shipped.add_to_manifest(folder, _entry(path, 4.77, [0.5, 1.0, 1.5]))
    return folder


@pytest.fixture(scope="module")
def experiments(mu_surrogate, tmp_path_factory):
    """Experiments of the surrogate's FE model: its test, another radius, another protocol."""
    spec = ModelSpec.from_dict(mu_surrogate.meta["campaign"]["model"])
    fe = FESolverPredictor(spec, parameters=("c1", "c5", "mu"))
    root = tmp_path_factory.mktemp("exps")
    made = {}
    for name, radius in (("same", 4.77), ("radius", 8.0)):
        made[name] = write_synthetic_experiment(fe, TRUTH, root / name, radius=radius, step_size=0.5, seed=1)
    made["protocol"] = root / "protocol"  # the same data recorded as 3 steps of 0.6 mm
    made["protocol"].mkdir()
    for item in made["same"].iterdir():
        if item.is_file():
            (made["protocol"] / item.name).write_bytes(item.read_bytes())
    meta = json.loads((made["protocol"] / "experiment.json").read_text())
    meta["step_size_mm"] = 0.6
    (made["protocol"] / "experiment.json").write_text(json.dumps(meta))
    return made


def test_the_manifest_lists_the_file_with_its_test_and_a_changed_byte_is_refused_by_name(
    shipped_folder, tmp_path
):
    (entry,) = shipped.shipped_surrogates(shipped_folder)
    assert entry.name == "test-R4.77-3x0.5" and entry.test == "R = 4.77 mm, 3 x 0.5 mm"
    assert entry.sha256 == shipped.file_sha256(entry.path) and len(entry.sha256) == 64
    model = shipped.load_shipped(entry)
    assert model.meta["shipped"] == {"name": entry.name, "file": entry.path.name, "sha256": entry.sha256}
    assert shipped.shipped_for_test(4.77, [0.5, 1.0, 1.5], folder=shipped_folder).path == entry.path
    assert shipped.shipped_for_test(8.0, [0.5, 1.0, 1.5], folder=shipped_folder) is None
    assert shipped.shipped_for_test(4.77, [0.5, 1.0, 1.5, 2.0], folder=shipped_folder) is None
    assert shipped.shipped_for_test(4.77, [0.6, 1.2, 1.8], folder=shipped_folder) is None
    # one byte changed in a copy of the folder: refused, naming the file and both hashes
    copy = tmp_path / "copy"
    copy.mkdir()
    for item in shipped_folder.iterdir():
        (copy / item.name).write_bytes(item.read_bytes())
    damaged = copy / entry.path.name
    data = bytearray(damaged.read_bytes())
    data[-100] ^= 0x01
    damaged.write_bytes(bytes(data))
    (bad,) = shipped.shipped_surrogates(copy)
    with pytest.raises(
        SurrogateFileError, match=rf"{damaged}: sha256 [0-9a-f]{{64}} is not the manifest's {entry.sha256}"
    ):
        shipped.load_shipped(bad)
    # a manifest entry whose file does not hash to it is not written
    with pytest.raises(SurrogateFileError, match="sha256"):
        shipped.add_to_manifest(copy, _entry(entry.path, 4.77, [0.5, 1.0, 1.5]) | {"file": damaged.name})


def test_a_fit_given_no_surrogate_takes_the_shipped_one_for_its_test_and_refuses_another_test(
    shipped_folder, experiments, monkeypatch
):
    monkeypatch.setattr(shipped, "shipped_surrogates_folder", lambda: shipped_folder)
    inputs = prepare_fit(experiments["same"])
    assert inputs.sources["surrogate"].startswith(
        "the shipped surrogate test-R4.77-3x0.5 (R = 4.77 mm, 3 x 0.5 mm"
    )
    assert inputs.surrogate.meta["shipped"]["sha256"] == shipped.file_sha256(
        shipped_folder / "test-R4.77-3x0.5.safetensors"
    )
    assert inputs.surrogate.parameters == ("c1", "c5", "mu")
    with pytest.raises(
        ValueError,
        match=r"no shipped surrogate matches this test \(R = 8 mm, 3 x 0.5 mm; shipped: R = 4\.77 mm, 3 x 0\.5 mm\)",
    ) as info:
        prepare_fit(experiments["radius"])
    assert "indent-studio test prepare --radius 8 --steps 3 --step-size 0.5" in str(info.value)
    with pytest.raises(
        ValueError, match=r"no shipped surrogate matches this test \(R = 4\.77 mm, 3 x 0\.6 mm"
    ):
        prepare_fit(experiments["protocol"])


def test_the_fit_command_says_it_uses_the_shipped_surrogate_and_records_it(
    shipped_folder, experiments, monkeypatch
):
    monkeypatch.setattr(shipped, "shipped_surrogates_folder", lambda: shipped_folder)
    res = CliRunner().invoke(app, ["fit", "--experiment", str(experiments["same"]), "--fe-stage", "none"])
    assert res.exit_code == 0, res.output
    assert "surrogate: the shipped surrogate test-R4.77-3x0.5" in res.output
    fit = json.loads((experiments["same"] / "results" / "fit.json").read_text())
    assert fit["inputs"]["surrogate"].startswith("the shipped surrogate test-R4.77-3x0.5")
    assert fit["inputs"]["surrogate_sha256"] == shipped.file_sha256(
        shipped_folder / "test-R4.77-3x0.5.safetensors"
    )
    res = CliRunner().invoke(app, ["fit", "--experiment", str(experiments["radius"]), "--json"])
    assert res.exit_code != 0 and "no shipped surrogate matches this test (R = 8 mm" in res.output


def test_the_package_ships_a_surrogate_with_mu_for_each_paper_test_and_each_matches_its_sha256():
    """The files in the package (issue 46): one per paper radius, 28 x 0.5 mm, over (c1, c5, mu),
    each hashing to its manifest's sha256, loading (its self check passed) and predicting the
    stick's force inside the box; its held-out errors carried from its low level."""
    from indentation_studio.surrogate.persistence import load_surrogate

    entries = shipped.shipped_surrogates()
    paper_depths = 0.5 * np.arange(1, 29)
    assert sorted(e.radius for e in entries) == [4.77, 8.0]
    for entry in entries:
        assert entry.matches(entry.radius, paper_depths) and entry.recipe.startswith("python tools/")
        path = entry.verified_path()  # size and sha256 against the manifest
        assert shipped.file_sha256(path) == entry.sha256 and path.stat().st_size == entry.bytes
        model = load_surrogate(path)
        assert tuple(model.parameters) == ("c1", "c5", "mu")
        assert model.meta["campaign"]["model"]["mesh"]["preset"] == "contact-L3"
        assert model.low.meta["campaign"]["model"]["mesh"]["preset"] == "contact-L1"
        errors = model.emulation_error
        assert errors.points == 512 and errors.directions.shape[1] == errors.width(model.n_nodes)
        force = model.predict(np.array([[10.0, 350.0, 1.0]])).force[0]
        assert np.all(np.diff(force) > 0) and 1e3 < force[-1] < 1e5  # mN at 14 mm
