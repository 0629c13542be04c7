"""Importers of lab files: one synthetic indentation experiment (coarse mesh, 4 steps) written as a
MatchID export folder, DuoDIC v7 and v7.3 files, a mapped (VIC-3D-like) CSV folder and the load
frame's continuous record, imported, gives the studio format's objective (residual vectors to 1e-6
relative) and fit; bad input is named by file, column or row and leaves nothing behind."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from lab_files import (
    frames_with_reference,
    load_frame_record,
    write_duodic_v7,
    write_duodic_v73,
    write_mat73,
    write_matchid,
    write_vic_csv,
)

from indentation_studio.forward.fe_predictor import FESolverPredictor
from indentation_studio.forward.predictor import Prediction
from indentation_studio.forward.spec import MeshChoice, ModelSpec, Protocol
from indentation_studio.inference.experiment.data import ExperimentDataError, load_experiment
from indentation_studio.inference.experiment.processing import experiment_objective, static_forces
from indentation_studio.inference.experiment.synthetic import write_synthetic_experiment
from indentation_studio.inference.fit.inverse_fit import fit_parameters
from indentation_studio.inference.lab.duodic_results import read_duodic
from indentation_studio.inference.lab.experiment_import import (
    ForceSource,
    FrameChoice,
    IndenterSource,
    ProtocolInfo,
    import_dic_csv,
    import_duodic,
    import_load_frame,
    import_matchid,
)
from indentation_studio.inference.lab.import_csv import CSVMapping
from indentation_studio.inference.lab.load_frame import LoadFrameColumns
from indentation_studio.inference.lab.matchid_export import read_matchid

SPEC = ModelSpec(mesh=MeshChoice("coarse"), protocol=Protocol(step_size=0.5, steps=4))
TRUE = np.array([12.0, 250.0])
ETA = (0.45, 0.35, 0.2, 0.0)
PROTOCOL = ProtocolInfo(radius_mm=4.77, step_size_mm=0.5, steps=4, fiber_angle_deg=60.0)


class LinearPredictor:
    """A small surrogate: the FE response at theta0 and its exact sensitivities, extended linearly."""

    parameters = ("c1", "c5")

    def __init__(self, base: Prediction, theta0: np.ndarray) -> None:
        self.base, self.theta0 = base, np.asarray(theta0, float)

    def predict(self, theta, jacobian: bool = False) -> Prediction:
        d = np.atleast_2d(np.asarray(theta, float)) - self.theta0
        b = self.base
        f = b.force[0] + np.einsum("sp,np->ns", b.force_jacobian[0], d)
        u = b.displacement[0] + np.einsum("skdp,np->nskd", b.displacement_jacobian[0], d)
        n = len(d)
        return Prediction(
            f,
            u,
            b.depth,
            b.top_xyz,
            b.parameters,
            np.repeat(b.force_jacobian, n, axis=0) if jacobian else None,
            np.repeat(b.displacement_jacobian, n, axis=0) if jacobian else None,
        )


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """The studio-format experiment and the same data as lab files."""
    root = tmp_path_factory.mktemp("lab")
    model = LinearPredictor(FESolverPredictor(SPEC).predict(TRUE, jacobian=True), TRUE)
    studio = write_synthetic_experiment(
        model, TRUE, root / "studio", radius=4.77, step_size=0.5, points=1500, seed=4
    )
    # points present in some steps and not in others (as DIC loses them)
    with np.load(studio / "dic.npz") as z:
        xyz, u = z["xyz"], z["u"].copy()
    rng = np.random.default_rng(0)
    u[rng.random(u.shape[:2]) < 0.04] = np.nan
    np.savez_compressed(studio / "dic.npz", xyz=xyz, u=u)
    exp = load_experiment(studio)
    force = pd.read_csv(studio / "force.csv")
    record, windows = load_frame_record(force, 0.5)
    record.to_csv(root / "record.csv", index=False)
    # DIC frames: the reference, then two per step (mid-hold, slightly less deformed, and at its end)
    frames = [np.zeros_like(exp.dic_u[0])]
    times = [5.0]
    for k in range(4):
        frames += [0.97 * exp.dic_u[k], exp.dic_u[k]]
        times += [windows[k].mean(), windows[k][1] - 0.5]
    frames = np.stack(frames)
    write_matchid(root / "matchid", exp.dic_xyz, frames)
    pd.DataFrame({"frame": np.arange(len(times)), "time [s]": times}).to_csv(
        root / "frame_times.csv", index=False
    )
    write_duodic_v7(root / "duodic_v7.mat", exp.dic_xyz, frames_with_reference(exp.dic_u))
    write_duodic_v73(root / "duodic_v73.mat", exp.dic_xyz, frames_with_reference(exp.dic_u))
    write_vic_csv(root / "vic", exp.dic_xyz, frames)
    return {"root": root, "studio": studio, "exp": exp, "model": model, "windows": windows}


def _residuals(exp, model, theta):
    objective, _ = experiment_objective(exp, model.base.top_xyz)
    return objective.residuals(model.predict(theta), ETA)[0], objective


def _imports(lab):
    root = lab["root"]
    record = ForceSource(load_frame=root / "record.csv")
    indenter = IndenterSource(lab["studio"] / "indenter.csv", "mm")
    by_time = FrameChoice(times_file=root / "frame_times.csv")
    vic = CSVMapping(
        {"x": "X", "y": "Y", "z": "Z", "ux": "U", "uy": "V", "uz": "W", "sigma": "sigma"}, length_unit="mm"
    )
    return {
        "matchid": lambda out: import_matchid(
            root / "matchid", out, protocol=PROTOCOL, force=record, indenter=indenter, frames=by_time
        ),
        **{
            name: lambda out, mat=mat: import_duodic(
                root / mat,
                out,
                protocol=PROTOCOL,
                force=record,
                indenter=indenter,
                length_unit="mm",
                frames=FrameChoice(frames=(1, 2, 3, 4)),
            )
            for name, mat in (("duodic-v7", "duodic_v7.mat"), ("duodic-v7.3", "duodic_v73.mat"))
        },
        "csv": lambda out: import_dic_csv(
            root / "vic", vic, out, protocol=PROTOCOL, force=record, indenter=indenter, frames=by_time
        ),
    }


@pytest.mark.parametrize("fmt", ["matchid", "duodic-v7", "duodic-v7.3", "csv"])
def test_imported_experiment_gives_the_studio_objective(lab, tmp_path, fmt):
    result = _imports(lab)[fmt](tmp_path / fmt)
    assert result.frames == ([2, 4, 6, 8] if fmt in ("matchid", "csv") else [1, 2, 3, 4])
    assert [h["step"] for h in result.holds] == [1, 2, 3, 4] and all(
        h["readings"] == 31 for h in result.holds
    )
    imported = load_experiment(tmp_path / fmt)
    studio = lab["exp"]
    assert imported.dic_u.shape == studio.dic_u.shape
    np.testing.assert_allclose(static_forces(imported)[0], static_forces(studio)[0], rtol=1e-9)
    for theta in (TRUE, np.array([8.0, 400.0])):
        r_imported, obj = _residuals(imported, lab["model"], theta)
        r_studio, ref = _residuals(studio, lab["model"], theta)
        assert np.array_equal(obj.measured, ref.measured) and obj.measured.sum() >= 10
        scale = np.abs(r_studio).max()
        assert np.abs(r_imported - r_studio).max() <= 1e-6 * scale, (
            np.abs(r_imported - r_studio).max() / scale
        )
    meta = json.loads((tmp_path / fmt / "experiment.json").read_text())
    assert meta["imported"]["frames"] == {str(k + 1): f for k, f in enumerate(result.frames)}


def test_imported_fit_equals_the_studio_fit(lab, tmp_path):
    _imports(lab)["matchid"](tmp_path / "m")
    fits = []
    for exp in (lab["exp"], load_experiment(tmp_path / "m")):
        objective, _ = experiment_objective(exp, lab["model"].base.top_xyz)
        fits.append(fit_parameters(objective, lab["model"], ETA))
    np.testing.assert_allclose(fits[1].theta, fits[0].theta, rtol=1e-6)
    np.testing.assert_allclose(fits[1].bounds_pct, fits[0].bounds_pct, rtol=1e-5)
    assert np.all(np.abs(fits[0].theta / TRUE - 1) < 0.05)  # the synthetic noise moves it a little


def test_matchid_points_missing_in_some_images(lab):
    dic = read_matchid(lab["root"] / "matchid")
    assert len(dic.frame_ids) == 9 and len(dic.xyz) == len(lab["exp"].dic_xyz)
    counts = dic.points_per_frame
    assert counts[0] == len(dic.xyz) and np.all(counts[1:] < len(dic.xyz))  # ~4 % lost per step
    assert np.all(np.isfinite(dic.xyz))


def test_load_frame_record_cut_into_holds(lab, tmp_path):
    out = import_load_frame(lab["root"] / "record.csv", tmp_path / "force.csv", PROTOCOL)
    starts = [h["start_s"] for h in out["holds"]]
    np.testing.assert_allclose(starts, lab["windows"][:, 0])
    assert out["holds"][0]["first_row"] == 23 and out["readings"] == 4 * 31
    written = pd.read_csv(tmp_path / "force.csv")
    original = pd.read_csv(lab["studio"] / "force.csv")
    np.testing.assert_allclose(written.to_numpy(), original.to_numpy(), rtol=1e-12, atol=1e-9)


# ------------------------------------------------------------------ bad input, named and nothing written


def _no_leftovers(out: Path) -> None:
    assert not out.exists()
    assert not [p for p in out.parent.iterdir() if p.name.startswith(f".{out.name}.")]


def test_matchid_folder_with_a_frame_missing(lab, tmp_path):
    folder = tmp_path / "matchid"
    shutil.copytree(lab["root"] / "matchid", folder)
    (folder / "Image_0003_0.tiff.csv").unlink()
    out = tmp_path / "out"
    with pytest.raises(
        ExperimentDataError, match=r"frame 3 is missing \(between Image_0002_0.tiff.csv and Image_0004"
    ):
        import_matchid(
            folder,
            out,
            protocol=PROTOCOL,
            force=ForceSource(load_frame=lab["root"] / "record.csv"),
            indenter=IndenterSource(lab["studio"] / "indenter.csv", "mm"),
            frames=FrameChoice(times_file=lab["root"] / "frame_times.csv"),
        )
    _no_leftovers(out)
    # naming the frames of the steps explicitly, a frame that is not there is named with its step
    with pytest.raises(ExperimentDataError, match=r"no frame 3 \(step 2\); the export has frames 0..2, 4..8"):
        import_matchid(
            folder,
            out,
            protocol=PROTOCOL,
            force=ForceSource(load_frame=lab["root"] / "record.csv"),
            indenter=IndenterSource(lab["studio"] / "indenter.csv", "mm"),
            frames=FrameChoice(frames=(2, 3, 6, 8)),
        )
    _no_leftovers(out)


def test_matchid_renamed_column(lab, tmp_path):
    folder = tmp_path / "matchid"
    shutil.copytree(lab["root"] / "matchid", folder)
    path = folder / "Image_0005_0.tiff.csv"
    path.write_text(path.read_text().replace("disp.Out-Of-Plane: W [mm]", "disp.W [mm]", 1))
    with pytest.raises(ExperimentDataError, match=r"Image_0005_0.tiff.csv: no column 'disp.Out-Of-Plane: W'"):
        read_matchid(folder)


def test_mat_without_points3d(tmp_path):
    import scipy.io

    write_mat73(tmp_path / "v73.mat", {"DIC3DPPresults": {"Faces": [np.ones((2, 3))]}})
    scipy.io.savemat(tmp_path / "v7.mat", {"DIC3DPPresults": {"Faces": np.ones((2, 3))}})
    for name in ("v73.mat", "v7.mat"):
        with pytest.raises(
            ExperimentDataError, match=rf"{name}: no 'Points3D' in DIC3DPPresults \(has Faces\)"
        ):
            read_duodic(tmp_path / name, "mm")

    scipy.io.savemat(tmp_path / "other.mat", {"calibration": np.eye(3)})
    with pytest.raises(
        ExperimentDataError, match=r"other.mat: no DuoDIC results: none of the variables \(calibration\)"
    ):
        read_duodic(tmp_path / "other.mat", "mm")


def _record(lab) -> pd.DataFrame:
    return pd.read_csv(lab["root"] / "record.csv")


def _import_record(lab, tmp_path, record: pd.DataFrame, columns=None, protocol=PROTOCOL):
    path = tmp_path / "record.csv"
    record.to_csv(path, index=False)
    return import_load_frame(
        path, tmp_path / "force.csv", protocol, ForceSource(columns=columns or LoadFrameColumns())
    )


def test_load_frame_record_without_holds(lab, tmp_path):
    record = _record(lab)
    record["Position [mm]"] = np.linspace(37.5, 35.0, len(record))  # a ramp, never held
    with pytest.raises(ExperimentDataError, match=r"record.csv: no hold found"):
        _import_record(lab, tmp_path, record)
    assert not (tmp_path / "force.csv").exists()


def test_fewer_holds_than_steps(lab, tmp_path):
    record = _record(lab)
    with pytest.raises(
        ExperimentDataError, match=r"found 4 holds but the protocol has 5 steps \(no hold at step\(s\) 5\)"
    ):
        _import_record(lab, tmp_path, record, protocol=ProtocolInfo(4.77, 0.5, 5))


def test_forces_in_newtons_declared_as_millinewtons(lab, tmp_path):
    record = _record(lab)
    with pytest.raises(ExperimentDataError, match=r"column 'Force \[N\]' states 'N' but 'mN' was declared"):
        _import_record(lab, tmp_path, record, LoadFrameColumns(force_unit="mN"))
    record = record.rename(columns={"Force [N]": "Force"})
    with pytest.raises(ExperimentDataError, match=r"column 'Force'.*cannot be millinewtons"):
        _import_record(lab, tmp_path, record, LoadFrameColumns(force_unit="mN"))
    assert _import_record(lab, tmp_path, record, LoadFrameColumns(force_unit="N"))["readings"] == 124


def test_load_cell_spike_named_by_step_and_row(lab, tmp_path):
    record = _record(lab)
    row = 60  # in step 2's hold (its rows 55..85 as an editor counts them)
    record.loc[row - 2, "Force [N]"] *= 3.0
    with pytest.raises(
        ExperimentDataError, match=rf"step 2, row {row}, column 'Force \[N\]'.*load-cell spike"
    ):
        _import_record(lab, tmp_path, record)
    # left out of the fit, the same record imports
    out = import_load_frame(
        tmp_path / "record.csv", tmp_path / "force.csv", ProtocolInfo(4.77, 0.5, 4, excluded_steps=(2,))
    )
    assert len(out["holds"]) == 4


def test_slipped_step_named_by_rows(lab, tmp_path):
    record = _record(lab)
    hold3 = (record["Time [s]"] >= lab["windows"][2, 0]) & (record["Time [s]"] <= lab["windows"][2, 1])
    record.loc[hold3, "Position [mm]"] += 0.2  # step 3 stopped 0.2 mm short
    with pytest.raises(
        ExperimentDataError, match=r"rows 87..117 .* hold at depth 1\.[23]\d* mm, between steps 2 and 3"
    ):
        _import_record(lab, tmp_path, record)


def test_one_bad_hold_in_force_csv_is_named_and_can_be_excluded(lab, tmp_path):
    exp_dir = tmp_path / "e"
    shutil.copytree(lab["studio"], exp_dir)
    force = pd.read_csv(exp_dir / "force.csv")
    force.loc[force.step == 3, "force_mN"] *= 1000.0  # one hold read in the wrong unit
    force.to_csv(exp_dir / "force.csv", index=False)
    with pytest.raises(
        ExperimentDataError, match=r"force.csv: step 3 \(rows 64..94\), column 'force_mN'.*excluded_steps"
    ):
        load_experiment(exp_dir)
    meta = json.loads((exp_dir / "experiment.json").read_text())
    meta["excluded_steps"] = [3]
    (exp_dir / "experiment.json").write_text(json.dumps(meta))
    exp = load_experiment(exp_dir)
    objective, _ = experiment_objective(exp, lab["model"].base.top_xyz)
    full, _ = experiment_objective(lab["exp"], lab["model"].base.top_xyz)
    assert objective.steps.tolist() == [0, 1, 3] and full.steps.tolist() == [0, 1, 2, 3]
    # the library argument does the same on the clean experiment: the same residuals
    by_argument, _ = experiment_objective(lab["exp"], lab["model"].base.top_xyz, excluded_steps=[3])
    pred = lab["model"].predict(TRUE)
    np.testing.assert_allclose(objective.residuals(pred, ETA), by_argument.residuals(pred, ETA), rtol=1e-12)
    assert by_argument.residuals(pred, ETA).shape[1] == 3 * (1 + 3 * int(by_argument.measured.sum()))


# ------------------------------------------------------------------ the CLI and the data check


def _cli(args: list[str]) -> dict:
    from typer.testing import CliRunner

    from indentation_studio.studio.cli import app

    res = CliRunner().invoke(app, [*args, "--json"])
    return json.loads(res.stdout.strip().splitlines()[-1]) | {"exit_code": res.exit_code}


def test_cli_import_and_check_of_an_imported_experiment(lab, tmp_path):
    root = lab["root"]
    common = ["--radius", "4.77", "--step-size", "0.5", "--steps", "4", "--fiber-angle", "60"]
    common += ["--indenter", str(lab["studio"] / "indenter.csv"), "--indenter-unit", "mm"]
    matchid = ["import", "matchid", "--dic", str(root / "matchid"), "--out", str(tmp_path / "e"), *common]
    matchid += ["--load-frame", str(root / "record.csv")]
    out = _cli([*matchid, "--frame-times", str(root / "frame_times.csv")])
    assert out["exit_code"] == 0 and out["frames"] == [2, 4, 6, 8] and len(out["holds"]) == 4
    again = _cli([*matchid, "--frames", "2:8:2"])
    assert again["exit_code"] == 1 and "exists and is not empty" in again["error"]
    check = _cli(["check", "--experiment", str(tmp_path / "e")])
    assert check["exit_code"] == 0 and check["warnings"] == []
    meta = json.loads((lab["studio"] / "experiment.json").read_text())["synthetic"]
    np.testing.assert_allclose(check["indentation_point_mm"], meta["frame_offset"], atol=0.01)
    assert (
        check["sphere_radius_mm"] == pytest.approx(4.77, abs=0.01) and check["sphere_residual_rms_mm"] < 0.003
    )
    # the noise the synthetic experiment added: 2 % of max |u| per direction of the model frame
    from indentation_studio.inference.experiment.processing import to_model_frame

    truth = 0.02 * np.nanmax(np.abs(to_model_frame(lab["exp"]).u), axis=(0, 1))
    np.testing.assert_allclose(check["dic_noise_mm"], truth, rtol=0.2)
    assert [c["points"] for c in check["coverage"]] == out["points_per_step"]
    assert 0 < check["nodes_with_data"] < check["nodes"] == 121
    for png in check["figures"]:
        assert Path(png).stat().st_size > 10_000
    assert "Data check" in Path(check["report"]).read_text()


def test_data_check_warns_with_numbers(lab, tmp_path):
    from indentation_studio.inference.experiment.data_check import check_experiment

    exp_dir = tmp_path / "e"
    shutil.copytree(lab["studio"], exp_dir)
    force = pd.read_csv(exp_dir / "force.csv")
    slow = force.step == 2  # a hold that has not relaxed: tau 60 s over a 30 s hold
    f_inf = force.loc[slow, "force_mN"].iloc[-1]
    force.loc[slow, "force_mN"] = f_inf * (1.0 + 0.4 * np.exp(-force.loc[slow, "time_s"] / 60.0))
    force.to_csv(exp_dir / "force.csv", index=False)
    indenter = pd.read_csv(exp_dir / "indenter.csv")
    indenter += 0.3 * np.random.default_rng(2).standard_normal(indenter.shape)  # not on the sphere
    indenter.to_csv(exp_dir / "indenter.csv", index=False)
    with np.load(exp_dir / "dic.npz") as z:
        xyz, u = z["xyz"], z["u"].copy()
    u[3] = np.nan  # the last step's DIC frame lost ...
    np.savez(exp_dir / "dic.npz", xyz=xyz, u=u)
    meta = json.loads((exp_dir / "experiment.json").read_text())
    meta["excluded_steps"] = [4]  # ... and the step left out
    (exp_dir / "experiment.json").write_text(json.dumps(meta))
    check = check_experiment(exp_dir)
    text = "\n".join(check.warnings)
    assert "step 4 is excluded from the fit (has force readings, no DIC points)" in text
    hold2 = check.holds[1]
    assert hold2.tau_s == pytest.approx(60.0, rel=0.05) and hold2.unrelaxed_pct > 10
    assert f"step 2: the hold has not relaxed: the force still carries {hold2.unrelaxed_pct:.2g} %" in text
    assert check.sphere_residual_rms_mm > 0.2 and "sphere fit's residual" in text
    assert [h.step for h in check.holds] == [1, 2, 3]
    # a step lost and not excluded: a fit refuses the folder, the check reports the step
    force[force.step != 3].to_csv(exp_dir / "force.csv", index=False)
    with pytest.raises(ExperimentDataError, match="step 3 has 0 force readings"):
        load_experiment(exp_dir)
    check = check_experiment(exp_dir)
    assert check.missing_steps == [3] and [h.step for h in check.holds] == [1, 2]
    points = int(np.isfinite(u[2]).all(axis=1).sum())
    assert f"step 3 is missing: 0 force readings, {points} DIC points" in "\n".join(check.warnings)


def test_long_csv_with_ids_current_positions_and_units_in_the_header(lab, tmp_path):
    """One long file (GOM-like: a frame column, a point id, current positions, units in the
    headers, rows in any order, points missing from some frames) reads as the VIC-like folder."""
    from indentation_studio.inference.lab.import_csv import read_dic_csv

    exp = lab["exp"]
    rows = []
    for k, u in enumerate(frames_with_reference(exp.dic_u)):
        ok = np.isfinite(u).all(axis=1)
        cur = exp.dic_xyz[ok] + u[ok]
        rows.append(
            pd.DataFrame(
                {
                    "Stage": k,
                    "Point ID": np.flatnonzero(ok),
                    "x [m]": cur[:, 0] / 1e3,
                    "y [m]": cur[:, 1] / 1e3,
                    "z [m]": cur[:, 2] / 1e3,
                    "dX [m]": u[ok, 0] / 1e3,
                    "dY [m]": u[ok, 1] / 1e3,
                    "dZ [m]": u[ok, 2] / 1e3,
                }
            )
        )
    table = pd.concat(rows).sample(frac=1.0, random_state=3)
    table.to_csv(tmp_path / "gom.csv", index=False, float_format="%.12e")
    mapping = CSVMapping.parse("x=x,y=y,z=z,ux=dX,uy=dY,uz=dZ,id=Point ID,frame=Stage", positions="current")
    dic = read_dic_csv(tmp_path / "gom.csv", mapping)
    assert dic.frame_ids.tolist() == [0, 1, 2, 3, 4]
    np.testing.assert_allclose(dic.xyz, exp.dic_xyz, atol=1e-9)
    np.testing.assert_allclose(dic.u[1:], exp.dic_u, atol=1e-9)
    with pytest.raises(
        ExperimentDataError, match=r"gom.csv: column 'x \[m\]' states 'm' but 'mm' was declared"
    ):
        read_dic_csv(tmp_path / "gom.csv", CSVMapping(mapping.columns, positions="current", length_unit="mm"))


def test_force_csv_in_hold_form_needs_the_frames_named(lab, tmp_path):
    root, studio = lab["root"], lab["studio"]
    force = ForceSource(force_csv=studio / "force.csv")
    indenter = IndenterSource(studio / "indenter.csv", "mm")
    kw = {"protocol": PROTOCOL, "force": force, "indenter": indenter, "length_unit": "mm"}
    with pytest.raises(ExperimentDataError, match="name the DIC frame of every step"):
        import_duodic(root / "duodic_v73.mat", tmp_path / "e", **kw)
    _no_leftovers(tmp_path / "e")
    import_duodic(root / "duodic_v73.mat", tmp_path / "e", **kw, frames=FrameChoice(frames=(1, 2, 3, 4)))
    r, _ = _residuals(load_experiment(tmp_path / "e"), lab["model"], TRUE)
    r_studio, _ = _residuals(lab["exp"], lab["model"], TRUE)
    assert np.abs(r - r_studio).max() <= 1e-6 * np.abs(r_studio).max()
