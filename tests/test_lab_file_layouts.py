"""Lab files as the programs write them: MatchID headers with commas inside brackets, a CSV saved
by Windows software (cp1252, a µ in a header), load-frame records in Instron Bluehill and MTS
TestSuite layouts (a header block and a unit row before the data), and DuoDIC files whose
MATLAB objects pymatreader cannot read (its warning said in the studio's words)."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest
from lab_files import (
    add_matchid_tensors,
    sampled_record,
    write_bluehill,
    write_mat73,
    write_matchid,
    write_testsuite,
)

from indentation_studio.inference.experiment.data import ExperimentDataError
from indentation_studio.inference.lab.csv_text import csv_encoding
from indentation_studio.inference.lab.duodic_results import read_duodic
from indentation_studio.inference.lab.experiment_import import ProtocolInfo, import_load_frame
from indentation_studio.inference.lab.load_frame import read_load_frame
from indentation_studio.inference.lab.matchid_export import read_matchid
from indentation_studio.inference.lab.table_columns import read_table


def _dic(n=300, frames=4, seed=0):
    rng = np.random.default_rng(seed)
    xyz = np.column_stack([rng.uniform(-10, 10, (n, 2)), np.zeros(n)])
    u = np.stack([k * 0.01 * rng.standard_normal((n, 3)) for k in range(frames)])
    u[2, :7] = np.nan  # points lost in one image
    return xyz, u


def test_matchid_headers_with_commas_inside_brackets(tmp_path):
    xyz, u = _dic()
    plain = write_matchid(tmp_path / "plain", xyz, u, frame_ids=[10, 11, 12, 13])
    tensors = add_matchid_tensors(write_matchid(tmp_path / "tensors", xyz, u, frame_ids=[10, 11, 12, 13]))
    header = (tensors / "Image_0010_0.tiff.csv").read_text().splitlines()[0]
    assert "defgradient.F[0,0] [-]," in header and len(header.split(",")) == 11 + 9 + 9  # 9 extra commas
    table = read_table(tensors / "Image_0010_0.tiff.csv")
    assert len(table.columns) == 20 and "defgradient.F[2,1] [-]" in table.columns
    assert table["ext.Current Image [#]"].eq(10).all()  # not shifted, not NaN
    a, b = read_matchid(plain), read_matchid(tensors)
    assert b.frame_ids.tolist() == [10, 11, 12, 13]
    np.testing.assert_array_equal(a.xyz, b.xyz)
    np.testing.assert_array_equal(a.u, b.u)


def test_header_and_data_field_counts_that_differ_are_named(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("a,b,c\n1,2\n3,4\n5,6\n")
    with pytest.raises(ExperimentDataError, match=r"bad.csv: line 1 has 3 header fields but line 2 has 2"):
        read_table(path)


def _cp1252_record(tmp_path):
    frame, _ = sampled_record(10, steps=3)
    frame = frame.rename(columns={"Position [mm]": "Position [µm]"})
    frame["Position [µm]"] *= 1e3
    path = tmp_path / "record.csv"
    path.write_bytes(frame.to_csv(index=False).encode("cp1252"))
    return path


def test_cp1252_file_with_micro_sign_in_a_header(tmp_path):
    path = _cp1252_record(tmp_path)
    assert b"\xb5m" in path.read_bytes()[:60]  # µ as Windows writes it, not UTF-8
    record = read_load_frame(path)
    assert record.columns["position"] == "Position [µm]"
    assert record.position_mm.max() == pytest.approx(38.5)
    assert any("read as cp1252" in n or "read as windows-1252" in n for n in record.notes), record.notes
    out = import_load_frame(path, tmp_path / "force.csv", ProtocolInfo(4.77, 0.5, 3))
    assert [h["step"] for h in out["holds"]] == [1, 2, 3]
    with csv_encoding("cp1252"):  # declared (--encoding cp1252): the same
        assert read_load_frame(path).notes == ["record.csv read as cp1252"]
    with (
        csv_encoding("utf-8"),
        pytest.raises(
            ExperimentDataError, match=r"record.csv: not readable as utf-8 \(byte \d+: b'\\xb5'\).*--encoding"
        ),
    ):
        read_load_frame(path)


def test_load_frame_exports_in_vendor_layouts(tmp_path):
    frame, F = sampled_record(100, steps=4, noise=0.002, drift_mN_per_s=0.01, seed=2)
    protocol = ProtocolInfo(4.77, 0.5, 4)
    results = {}
    for name, writer in (("bluehill", write_bluehill), ("testsuite", write_testsuite)):
        path = writer(tmp_path / f"{name}.csv", frame)
        record = read_load_frame(path)
        results[name] = import_load_frame(path, tmp_path / f"{name}-force.csv", protocol)
        assert record.first_line == (9 if name == "bluehill" else 8)
        assert results[name]["holds"][0]["first_row"] > record.first_line
        first = results[name]["holds"][0]["first_row"]  # the row an editor shows for it
        line = path.read_text().splitlines()[first - 1]
        assert float(line.replace('"', "").split("," if name == "bluehill" else "\t")[0]) == pytest.approx(
            results[name]["holds"][0]["start_s"]
        )
    assert read_load_frame(tmp_path / "bluehill.csv").columns == {
        "time": "Time [s]",
        "position": "Extension [mm]",
        "force": "Load [N]",
    }
    assert read_load_frame(tmp_path / "testsuite.csv").columns == {
        "time": "Running Time [sec]",
        "position": "Crosshead [mm]",
        "force": "Axial Force [kN]",  # the unit row's kN: forces 1e6 mN each
    }
    f = [np.array([h["f_inf_mN"] for h in r["holds"]]) for r in results.values()]
    np.testing.assert_allclose(f[0], F, rtol=2e-3)
    np.testing.assert_allclose(f[1], f[0], rtol=1e-6)


def test_pymatreader_warning_becomes_a_note(tmp_path):
    xyz, u = _dic(n=50, frames=3)
    u[2, :7] = 0.0
    points = [xyz + v for v in u]
    path = write_mat73(
        tmp_path / "r.mat",
        {"DIC3DPPresults": {"Points3D": points, "Disp": {"DispVec": [p - points[0] for p in points]}}},
    )
    import h5py

    with h5py.File(path, "a") as f:  # an object DuoDIC saves beside the results (a MATLAB class)
        ds = f["DIC3DPPresults"].create_dataset("cameraParams", data=np.zeros((1, 6), np.uint32))
        ds.attrs["MATLAB_class"] = np.bytes_("cameraParameters")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # nothing printed by the library
        dic = read_duodic(path, "mm")
    assert any("MATLAB object(s) in the file" in n for n in dic.notes), dic.notes
    assert pd.notna(dic.u).all()
