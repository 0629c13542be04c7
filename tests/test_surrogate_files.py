"""Surrogate files that run no code when opened: exact round trips of both kinds, pickles refused
by name without being unpickled, the one-time conversion of old joblib files."""

from __future__ import annotations

import gzip
import json
import os
import pickle
import struct
import zipfile

import joblib
import numpy as np
import pytest
from safetensors.numpy import save as save_safetensors
from typer.testing import CliRunner

from indentation_studio.campaign.designs import design_from_option
from indentation_studio.campaign.loader import load_campaign
from indentation_studio.campaign.runner import run_campaign
from indentation_studio.campaign.spec import CampaignSpec
from indentation_studio.campaign.store import CampaignStore
from indentation_studio.forward.spec import MeshChoice, ModelSpec, Protocol
from indentation_studio.studio.cli import app
from indentation_studio.surrogate.base import TrainingData
from indentation_studio.surrogate.persistence import load_surrogate, save_surrogate
from indentation_studio.surrogate.pickle_conversion import convert_pickled_surrogate
from indentation_studio.surrogate.safe_file import (
    FORMAT,
    SurrogateFileError,
    file_kind,
    read_container,
    write_container,
)
from indentation_studio.surrogate.training import make_surrogate

MODEL = ModelSpec(protocol=Protocol(step_size=0.5, steps=3), mesh=MeshChoice("coarse"))
SMALL_MLP = {
    "adam_epochs": 200,
    "lbfgs_steps": 20,
    "ensemble": 2,
    "width": 16,
    "hidden_layers": 2,
}  # not the defaults
# inside the 4..16 x 150..500 box, off the grid, and one outside it (the surrogate extrapolates)
THETA = np.array([[9.3, 310.0], [4.6, 480.0], [15.2, 160.0], [18.0, 120.0]])


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    root = tmp_path_factory.mktemp("runs")
    spec = CampaignSpec("small", design_from_option("c1=4:16:4,c5=150:500:4"), MODEL)
    # one process: the suite's two workers already take CI's two cores (a second one only waits)
    assert run_campaign(CampaignStore.create_or_open(root, spec), jobs=1)["failed"] == 0
    return root, TrainingData.from_campaign(load_campaign("small", root))


def _train(kind: str, data: TrainingData):
    model = make_surrogate(kind, **(SMALL_MLP if kind == "mlp" else {})).fit(data, seed=0)
    model.meta["validation"] = {"training": {"force_rms_pct": np.float64(0.25), "points": np.int64(16)}}
    return model


@pytest.fixture(scope="module")
def small_gp(campaign):
    return _train("gp", campaign[1])


@pytest.fixture(scope="module", params=["gp", "mlp"])
def trained(request, campaign, small_gp):
    return small_gp if request.param == "gp" else _train("mlp", campaign[1])


def assert_same_predictions(a, b) -> None:
    pa, pb = a.predict(THETA, jacobian=True), b.predict(THETA, jacobian=True)
    for name in ("force", "displacement", "force_jacobian", "displacement_jacobian"):
        np.testing.assert_array_equal(getattr(pa, name), getattr(pb, name), err_msg=name)
    assert pa.force.shape == (4, 3) and pa.displacement_jacobian.shape[-1] == 2
    if a.kind == "gp":
        np.testing.assert_array_equal(a.predict_std(THETA), b.predict_std(THETA))


def test_round_trip_is_bit_for_bit(trained, tmp_path):
    path = save_surrogate(trained, tmp_path / f"surrogate-{trained.kind}.safetensors")
    assert file_kind(path) == "safetensors"
    header, arrays = read_container(path)
    assert header["format"] == FORMAT == "indentation-studio-surrogate/2" and header["kind"] == trained.kind
    assert all(a.dtype.kind in "fiub" for a in arrays.values())
    again = load_surrogate(path)
    assert type(again) is type(trained) and again.hyperparameters() == trained.hyperparameters()
    assert_same_predictions(trained, again)
    # the provenance comes back as the JSON it was written as (numpy numbers as plain numbers)
    assert again.meta == json.loads(json.dumps(trained.meta, default=float))
    assert again.meta["validation"]["training"]["points"] == 16 and again.meta["training_points"] == 16
    assert again.meta["versions"]["safetensors"] and again.meta["campaign"]["name"] == "small"
    if trained.kind == "gp":  # every fitted attribute of scikit-learn's GP rebuilt, but its RNG
        for gp, gp_again in zip(trained.gps, again.gps, strict=True):
            assert set(vars(gp_again)) == set(vars(gp)) - {"_rng"}
            assert repr(gp_again.kernel_) == repr(gp.kernel_)
            assert gp_again.L_.flags.f_contiguous and gp_again.alpha_.flags.f_contiguous
    else:
        assert len(again.nets) == 2 and all(not net.training for net in again.nets)


class RunsCodeWhenUnpickled:
    """Unpickling this makes the directory ``marker`` (standing for any command an attacker likes)."""

    def __init__(self, marker: str) -> None:
        self.marker = marker

    def __reduce__(self):
        return (os.mkdir, (self.marker,))


def _write_pickle(kind: str, path, payload) -> None:
    if kind == "pickle-5":
        path.write_bytes(pickle.dumps(payload, protocol=5))
    elif kind == "pickle-0":
        path.write_bytes(pickle.dumps(payload, protocol=0))
    elif kind == "joblib":
        joblib.dump(payload, path)
    elif kind == "joblib-zlib":
        joblib.dump(payload, path, compress=3)
    else:
        path.write_bytes(gzip.compress(pickle.dumps(payload)))


@pytest.mark.parametrize("kind", ["pickle-5", "pickle-0", "joblib", "joblib-zlib", "gzip"])
def test_a_pickle_is_refused_without_running_it(kind, tmp_path):
    marker = tmp_path / "code-was-run"
    evil = tmp_path / "surrogate-gp.joblib"
    _write_pickle(
        kind, evil, {"format": "indentation-studio-surrogate/1", "model": RunsCodeWhenUnpickled(str(marker))}
    )
    with pytest.raises(
        SurrogateFileError, match=r"is a (pickle \(joblib\) surrogate|compressed joblib)"
    ) as info:
        load_surrogate(evil)
    assert "indent-studio surrogate convert" in str(info.value) and str(evil) in str(info.value)
    res = CliRunner().invoke(app, ["surrogate", "evaluate", "--model", str(evil), "--json"])
    assert res.exit_code == 1 and "pickle" in json.loads(res.stdout)["error"]
    assert not marker.exists()
    joblib.load(evil)  # what the old loader did: the file was live
    assert marker.is_dir()


def test_other_files_are_refused_by_name(small_gp, tmp_path):
    cases = {
        "text": (b"not a model", "not an Indentation Studio surrogate file (unknown format)"),
        "empty": (b"", "unknown format"),
        "npz": (None, "zip (or npz) archive"),
        "foreign": (save_safetensors({"w": np.ones(3)}), "safetensors file but not an Indentation Studio"),
        "future": (
            save_safetensors({"w": np.ones(3)}, metadata={"format": "indentation-studio-surrogate/3"}),
            "reads 'indentation-studio-surrogate/2'",
        ),
    }
    for name, (content, message) in cases.items():
        path = tmp_path / f"{name}.safetensors"
        if content is None:
            with zipfile.ZipFile(path, "w") as zf:
                zf.writestr("a.npy", b"\x93NUMPY")
        else:
            path.write_bytes(content)
        with pytest.raises(SurrogateFileError, match=message.replace("(", r"\(").replace(")", r"\)")):
            load_surrogate(path)
    good = save_surrogate(small_gp, tmp_path / "good.safetensors").read_bytes()
    (header_len,) = struct.unpack("<Q", good[:8])
    (tmp_path / "cut.safetensors").write_bytes(good[: len(good) - 100])
    with pytest.raises(SurrogateFileError, match="damaged surrogate file"):
        load_surrogate(tmp_path / "cut.safetensors")
    # a changed number among the weights: the file reads, the self check catches it
    header = json.loads(good[8 : 8 + header_len])
    start, _ = header["gp0.alpha_"]["data_offsets"]
    body = bytearray(good)
    body[8 + header_len + start : 8 + header_len + start + 8] = struct.pack("<d", 123.0)
    (tmp_path / "changed.safetensors").write_bytes(bytes(body))
    with pytest.raises(SurrogateFileError, match="does not reproduce its saved predictions"):
        load_surrogate(tmp_path / "changed.safetensors")
    # a header that names a class outside the fixed lists, or sets a method: refused, nothing built
    header, arrays = read_container(tmp_path / "good.safetensors")
    for change, message in (
        (lambda c: c["regressor"]["gps"][0].update({"class": "Pipeline"}), "'Pipeline' is not one of"),
        (lambda c: c["regressor"]["gps"][0]["params"]["kernel"].update({"__kernel__": "system"}), "'system'"),
        (lambda c: c["force_pca"]["attributes"].update({"transform": "x"}), "'transform' is not a fitted"),
        (lambda c: c.update({"kind": "nn"}), "unknown surrogate kind 'nn'"),
    ):
        config = json.loads(header["surrogate"])
        change(config)
        write_container(tmp_path / "edited.safetensors", {**header, "surrogate": json.dumps(config)}, arrays)
        with pytest.raises(SurrogateFileError, match=message):
            load_surrogate(tmp_path / "edited.safetensors")
    with pytest.raises(FileNotFoundError, match="no surrogate file"):
        load_surrogate(tmp_path / "none.safetensors")


def test_convert_an_old_joblib_file_exactly(trained, tmp_path):
    old = tmp_path / f"surrogate-{trained.kind}.joblib"
    trained.meta["versions"] = {"torch": "old"}
    joblib.dump({"format": "indentation-studio-surrogate/1", "model": trained}, old)  # as format 1 did
    with pytest.raises(SurrogateFileError, match="pickle"):
        load_surrogate(old)
    new = tmp_path / "new.safetensors"
    res = CliRunner().invoke(app, ["surrogate", "convert", "--model", str(old), "--out", str(new), "--json"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout) == {"model_file": str(new), "converted_from": str(old)}
    again = load_surrogate(new)
    assert_same_predictions(trained, again)
    assert again.meta["converted_from"]["versions"] == {"torch": "old"}
    assert again.meta["converted_from"]["format"] == "indentation-studio-surrogate/1"
    with pytest.raises(SurrogateFileError, match="already a safe"):
        convert_pickled_surrogate(new, tmp_path / "again.safetensors")
    (tmp_path / "list.joblib").write_bytes(pickle.dumps([1, 2]))
    res = CliRunner().invoke(
        app, ["surrogate", "convert", "--model", str(tmp_path / "list.joblib"), "--out", str(new), "--json"]
    )
    assert res.exit_code == 1 and "not an Indentation Studio surrogate" in json.loads(res.stdout)["error"]
    assert "UNPICKLES" in CliRunner().invoke(app, ["surrogate", "convert", "--help"]).stdout


def test_cli_writes_safetensors_by_default(campaign):
    root, _ = campaign
    res = CliRunner().invoke(
        app, ["surrogate", "train", "--campaign", "small", "--kind", "gp", "--runs-dir", str(root), "--json"]
    )
    assert res.exit_code == 0, res.output
    path = json.loads(res.stdout)["model_file"]
    assert path == str(root / "small" / "surrogate-gp.safetensors") and file_kind(path) == "safetensors"
    res = CliRunner().invoke(app, ["surrogate", "evaluate", "--model", path, "--timing", "100", "--json"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["kind"] == "gp"
