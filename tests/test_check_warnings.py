"""``check`` catches what is wrong with a DIC field, with numbers: correlated points inside the
contact radius (a wrong registration), a field with no indentation (wrong frames), a step whose
point count drops (half the points lost), the reference positions' spread about the top face
beyond the DIC noise; the clean experiment raises none of them."""

from __future__ import annotations

import shutil

import numpy as np
import pandas as pd
import pytest
from test_lab_importers import SPEC, TRUE, LinearPredictor

from indentation_studio.forward.fe_predictor import FESolverPredictor
from indentation_studio.inference.experiment.data_check import check_experiment
from indentation_studio.inference.experiment.synthetic import write_synthetic_experiment


@pytest.fixture(scope="module")
def clean(tmp_path_factory):
    root = tmp_path_factory.mktemp("checks")
    model = LinearPredictor(FESolverPredictor(SPEC).predict(TRUE, jacobian=True), TRUE)
    return write_synthetic_experiment(
        model, TRUE, root / "clean", radius=4.77, step_size=0.5, points=1500, seed=4
    )


def _copy(clean, tmp_path, change):
    out = tmp_path / "copy"
    shutil.copytree(clean, out)
    with np.load(out / "dic.npz") as z:
        xyz, u = z["xyz"].copy(), z["u"].copy()
    xyz, u = change(xyz, u, out)
    np.savez_compressed(out / "dic.npz", xyz=xyz, u=u)
    return check_experiment(out, mesh="coarse")


def test_clean_experiment_has_none_of_these_warnings(clean):
    check = check_experiment(clean, mesh="coarse")
    text = " ".join(check.warnings)
    for phrase in ("inside the indenter's contact radius", "no indentation", "fewer than step", "top face"):
        assert phrase not in text, check.warnings
    assert check.points_inside_contact == []
    assert check.indentation_signature_mm < -0.1 * 2.0  # the surface beside the indenter sinks
    assert check.registration["tilt_deg"] < 1e-6


def test_points_inside_the_contact_radius(clean, tmp_path):
    def add_points_under_the_indenter(xyz, u, out):
        ind = pd.read_csv(out / "indenter.csv").to_numpy()
        centre = ind.mean(axis=0)  # near the axis, over the surface
        rng = np.random.default_rng(0)
        extra = np.column_stack([centre[:2] + rng.uniform(-1, 1, (20, 2)), np.full(20, xyz[0, 2])])
        u_extra = np.zeros((u.shape[0], 20, 3))
        u_extra[..., 2] = -0.5 * np.arange(1, u.shape[0] + 1)[:, None]  # moving down with the indenter
        return np.concatenate([xyz, extra]), np.concatenate([u, u_extra], axis=1)

    check = _copy(clean, tmp_path, add_points_under_the_indenter)
    warning = next(w for w in check.warnings if "inside the indenter's contact radius" in w)
    assert "step 1: 20 within 0.9 a" in warning and "step 4: 20 within" in warning
    assert [c["points"] for c in check.points_inside_contact] == [20, 20, 20, 20]


def test_a_step_with_half_the_points(clean, tmp_path):
    def lose_half(xyz, u, out):
        u[2, ::2] = np.nan
        return xyz, u

    check = _copy(clean, tmp_path, lose_half)
    assert any(w.startswith("step 3: ") and "% fewer than step 2's" in w for w in check.warnings), (
        check.warnings
    )


def test_a_field_with_no_indentation(clean, tmp_path):
    def no_indentation(xyz, u, out):
        rng = np.random.default_rng(1)
        return xyz, 0.01 * rng.standard_normal(u.shape)

    check = _copy(clean, tmp_path, no_indentation)
    assert any("the DIC field shows no indentation" in w for w in check.warnings), check.warnings


def test_spread_about_the_top_face_beyond_the_noise(clean, tmp_path):
    def bumpy(xyz, u, out):
        rng = np.random.default_rng(2)
        xyz[:, 2] += 0.3 * rng.standard_normal(len(xyz))
        return xyz, u

    check = _copy(clean, tmp_path, bumpy)
    assert any("spread about the top face (0.3" in w for w in check.warnings), check.warnings
