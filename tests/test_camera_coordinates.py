"""DIC in camera coordinates (the specimen tilted 16 degrees about an axis in its face and 250 mm
from the camera, as stereo-DIC programs reconstruct it) imported as a MatchID export and fitted:
noise-free, the same fit as the studio's own format to 1e-6 relative and the tilt recovered to
1e-6 rad; with 0.02 mm noise on the reconstructed positions, the tilt within what that noise
allows (4 standard deviations of the plane's slope, printed); an indenter that is not on the
face is refused with its distance."""

from __future__ import annotations

import shutil

import numpy as np
import pandas as pd
import pytest
from lab_files import frames_with_reference, write_matchid
from test_lab_importers import ETA, SPEC, TRUE, LinearPredictor

from indentation_studio.forward.fe_predictor import FESolverPredictor
from indentation_studio.inference.experiment.data import ExperimentDataError, load_experiment
from indentation_studio.inference.experiment.processing import experiment_objective, to_model_frame
from indentation_studio.inference.experiment.synthetic import write_synthetic_experiment
from indentation_studio.inference.fit.inverse_fit import fit_parameters
from indentation_studio.inference.lab.experiment_import import (
    ForceSource,
    FrameChoice,
    IndenterSource,
    ProtocolInfo,
    import_matchid,
)

TILT = np.radians(16.0)
AXIS = np.array([np.cos(np.radians(30.0)), np.sin(np.radians(30.0)), 0.0])  # in the face
SHIFT = np.array([5.0, -3.0, 250.0])


def _rotation(axis, angle):
    k = np.asarray(axis) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


R_TRUE = _rotation(AXIS, TILT)


def _angle(R):
    return float(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1)))


@pytest.fixture(scope="module")
def studio(tmp_path_factory):
    root = tmp_path_factory.mktemp("camera")
    model = LinearPredictor(FESolverPredictor(SPEC).predict(TRUE, jacobian=True), TRUE)
    path = write_synthetic_experiment(
        model, TRUE, root / "studio", radius=4.77, step_size=0.5, points=1500, seed=4
    )
    return {"root": root, "path": path, "exp": load_experiment(path), "model": model}


def _camera_import(studio, name, position_noise=0.0, indenter_shift=0.0):
    """The studio experiment rotated and shifted into camera coordinates, written as a MatchID
    export (+ indenter CSV, force.csv), and imported."""
    exp, root = studio["exp"], studio["root"] / name
    rng = np.random.default_rng(7)
    xyz = exp.dic_xyz @ R_TRUE.T + SHIFT + position_noise * rng.standard_normal(exp.dic_xyz.shape)
    u = exp.dic_u @ R_TRUE.T
    write_matchid(root / "matchid", xyz, frames_with_reference(u))
    ind = exp.indenter_xyz @ R_TRUE.T + SHIFT + indenter_shift * (R_TRUE @ [0.0, 0.0, 1.0])
    pd.DataFrame(ind, columns=["x [mm]", "y [mm]", "z [mm]"]).to_csv(root / "indenter.csv", index=False)
    f = R_TRUE @ [np.cos(np.radians(exp.fiber_angle_deg)), np.sin(np.radians(exp.fiber_angle_deg)), 0.0]
    protocol = ProtocolInfo(4.77, 0.5, 4, float(np.degrees(np.arctan2(f[1], f[0]))))
    import_matchid(
        root / "matchid",
        root / "exp",
        protocol=protocol,
        force=ForceSource(force_csv=studio["path"] / "force.csv"),
        indenter=IndenterSource(root / "indenter.csv", columns=("x [mm]", "y [mm]", "z [mm]")),
        frames=FrameChoice(frames=(1, 2, 3, 4)),
    )
    return load_experiment(root / "exp")


def _fit(exp, model):
    objective, dic = experiment_objective(exp, model.base.top_xyz)
    return fit_parameters(objective, model, ETA), dic


def test_camera_coordinates_noise_free(studio):
    camera = _camera_import(studio, "clean")
    fit_studio, reg_studio = _fit(studio["exp"], studio["model"])
    fit_camera, reg = _fit(camera, studio["model"])
    np.testing.assert_allclose(fit_camera.theta, fit_studio.theta, rtol=1e-6)
    np.testing.assert_allclose(fit_camera.bounds_pct, fit_studio.bounds_pct, rtol=1e-5)
    assert _angle(reg.frame.leveling @ R_TRUE) <= 1e-6  # the tilt undone
    assert reg.frame.tilt_deg == pytest.approx(16.0, abs=1e-6)
    np.testing.assert_allclose(reg.origin, reg_studio.origin @ R_TRUE.T + SHIFT, atol=1e-6)
    assert reg.fiber_angle_deg == pytest.approx(reg_studio.fiber_angle_deg, abs=1e-6)
    record = reg.to_dict()  # what fit.json's registration holds
    assert {"origin_mm", "rotation", "leveling_rotation", "surface_normal", "tilt_deg"} <= set(record)
    assert abs(record["indentation_point_off_surface_mm"]) < 1e-3  # as in the studio format (sphere fit)


def test_camera_coordinates_with_noise(studio):
    sigma = 0.02
    camera = _camera_import(studio, "noisy", position_noise=sigma)
    reg = to_model_frame(camera)
    err = _angle(reg.frame.leveling @ R_TRUE)
    # what the noise allows: the plane's slope error, sigma / sqrt(sum of squared in-plane
    # distances) along the worse direction of the field of view
    xy = studio["exp"].dic_xyz[:, :2] - studio["exp"].dic_xyz[:, :2].mean(axis=0)
    sd = sigma / np.sqrt(np.linalg.eigvalsh(xy.T @ xy).min())
    print(f"tilt error {err:.3g} rad, noise allows sd {sd:.3g} rad per direction")
    assert err <= 4 * np.sqrt(2) * sd
    assert reg.frame.surface_noise_mm == pytest.approx(sigma, rel=0.1)


def test_indenter_off_the_face_is_refused_with_its_distance(studio):
    camera = _camera_import(studio, "off", indenter_shift=2.0)
    with pytest.raises(
        ExperimentDataError,
        match=r"indentation point .* lies \+2 mm from the face the DIC points define \(limit 0.5 mm",
    ):
        to_model_frame(camera)
    shutil.rmtree(studio["root"] / "off")
