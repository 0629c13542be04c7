"""Lab files made from a studio experiment for the importer tests: a MatchID export folder, DuoDIC
results as MATLAB v7 (scipy) and v7.3 (HDF5 in MATLAB's layout, h5py) files, a mapped CSV, and
the load frame's continuous record. No third-party data: everything is written here."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pandas as pd
import scipy.io

MATCHID_HEADERS = {
    "image_x": "Coordinates.Image X [Pixel]",
    "image_y": "Coordinates.Image Y [Pixel]",
    "x": "coor.X [mm]",
    "y": "coor.Y [mm]",
    "z": "coor.Z [mm]",
    "ux": "disp.Horizontal Displacement U [mm]",
    "uy": "disp.Vertical Displacement V [mm]",
    "uz": "disp.Out-Of-Plane: W [mm]",
    "mag": "disp.Displacement Magnitude [mm]",
    "sigma": "stats.Sigma [mm]",
    "frame": "ext.Current Image [#]",
}


def frames_with_reference(u_steps: np.ndarray, extra: int = 0) -> np.ndarray:
    """Frames (1 + steps + extra, points, 3): the reference (zero), the steps, and ``extra``
    frames after the last step (the indenter lifted: zero again)."""
    zero = np.zeros_like(u_steps[:1])
    return np.concatenate([zero, u_steps, np.repeat(zero, extra, axis=0)])


def write_matchid(
    folder: Path, xyz: np.ndarray, frames_u: np.ndarray, frame_ids=None, scale: float = 1.0
) -> Path:
    """One MatchID CSV per frame (``Image_NNNN_0.tiff.csv``); rows whose displacement is NaN are
    left out (the point was not correlated in that image); coordinates are current positions."""
    folder.mkdir(parents=True, exist_ok=True)
    frame_ids = range(len(frames_u)) if frame_ids is None else frame_ids
    pix = np.column_stack([np.arange(len(xyz)) % 97 * 10 + 5, np.arange(len(xyz)) // 97 * 10 + 5])
    h = MATCHID_HEADERS
    for fid, u in zip(frame_ids, frames_u, strict=True):
        ok = np.isfinite(u).all(axis=1)
        cur = xyz + np.nan_to_num(u)
        table = pd.DataFrame(
            {
                h["image_x"]: pix[ok, 0],
                h["image_y"]: pix[ok, 1],
                h["x"]: cur[ok, 0] * scale,
                h["y"]: cur[ok, 1] * scale,
                h["z"]: cur[ok, 2] * scale,
                h["ux"]: u[ok, 0] * scale,
                h["uy"]: u[ok, 1] * scale,
                h["uz"]: u[ok, 2] * scale,
                h["mag"]: np.linalg.norm(u[ok], axis=1) * scale,
                h["sigma"]: 0.005,
                h["frame"]: fid,
            }
        )
        # shuffled rows, as correlation order is not the points' order
        table = table.sample(frac=1.0, random_state=int(fid))
        table.to_csv(folder / f"Image_{fid:04d}_0.tiff.csv", index=False, float_format="%.10E")
    return folder


def _cell(arrays) -> np.ndarray:
    out = np.empty((1, len(arrays)), dtype=object)
    for i, a in enumerate(arrays):
        out[0, i] = a
    return out


def duodic_struct(xyz: np.ndarray, frames_u: np.ndarray) -> dict:
    points = [xyz + u for u in frames_u]  # NaN where not reconstructed
    return {
        "Points3D": [p for p in points],
        "Disp": {"DispVec": [p - points[0] for p in points]},
        "corrComb": [np.where(np.isfinite(u).all(axis=1), 0.01, np.nan)[:, None] for u in frames_u],
    }


def write_duodic_v7(path: Path, xyz: np.ndarray, frames_u: np.ndarray, name: str = "DIC3DPPresults") -> Path:
    s = duodic_struct(xyz, frames_u)
    scipy.io.savemat(
        path,
        {
            name: {
                "Points3D": _cell(s["Points3D"]),
                "Disp": {"DispVec": _cell(s["Disp"]["DispVec"])},
                "corrComb": _cell(s["corrComb"]),
            }
        },
    )
    return path


def _h5_write(group: h5py.Group, key: str, value, refs: h5py.Group) -> None:
    """One MATLAB value in the v7.3 layout: a struct is a group, a cell a dataset of object
    references into '#refs#', a double matrix a dataset stored transposed (column-major)."""
    if isinstance(value, dict):
        sub = group.create_group(key)
        sub.attrs["MATLAB_class"] = np.bytes_("struct")
        for k, v in value.items():
            _h5_write(sub, k, v, refs)
    elif isinstance(value, list):
        ds = group.create_dataset(key, (len(value), 1), dtype=h5py.ref_dtype)  # MATLAB 1 x n
        for i, item in enumerate(value):
            name = f"{key}_{id(value)}_{i}"
            target = refs.create_dataset(name, data=np.asarray(item, float).T)
            target.attrs["MATLAB_class"] = np.bytes_("double")
            ds[i, 0] = target.ref
        ds.attrs["MATLAB_class"] = np.bytes_("cell")
    else:
        ds = group.create_dataset(key, data=np.atleast_2d(np.asarray(value, float)).T)
        ds.attrs["MATLAB_class"] = np.bytes_("double")


def write_mat73(path: Path, variables: dict) -> Path:
    """A MATLAB v7.3 file: HDF5 with MATLAB's 128-byte header in a 512-byte user block."""
    with h5py.File(path, "w", userblock_size=512) as f:
        refs = f.create_group("#refs#")
        for name, value in variables.items():
            _h5_write(f, name, value, refs)
    header = (
        b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Nov 23 12:00:00 2026 HDF5 schema 1.00 ."
    )
    with open(path, "r+b") as fh:
        fh.write(header.ljust(116, b" ") + b"\x00" * 8 + b"\x00\x02" + b"IM")
    return path


def write_duodic_v73(path: Path, xyz: np.ndarray, frames_u: np.ndarray, name: str = "DIC3DPPresults") -> Path:
    return write_mat73(path, {name: duodic_struct(xyz, frames_u)})


def write_vic_csv(folder: Path, xyz: np.ndarray, frames_u: np.ndarray) -> Path:
    """VIC-3D-like per-frame CSVs: quoted headers "X","Y","Z","U","V","W","sigma" (reference
    positions, mm); every point in every file, sigma = -1 where not correlated."""
    folder.mkdir(parents=True, exist_ok=True)
    for k, u in enumerate(frames_u):
        ok = np.isfinite(u).all(axis=1)
        table = pd.DataFrame(
            {
                "X": xyz[:, 0],
                "Y": xyz[:, 1],
                "Z": xyz[:, 2],
                "U": np.where(ok, u[:, 0], 0.0),
                "V": np.where(ok, u[:, 1], 0.0),
                "W": np.where(ok, u[:, 2], 0.0),
                "sigma": np.where(ok, 0.004, -1.0),
            }
        )
        table.to_csv(folder / f"spec_{k:04d}.csv", index=False, float_format="%.10E", quoting=2)
    return folder


def load_frame_record(
    force: pd.DataFrame,
    step_size: float,
    dt: float = 1.0,
    pre_s: float = 20.0,
    move_s: float = 2.0,
    position0: float = 37.5,
    newtons: bool = True,
    noise: float = 0.0,
    seed: int = 0,
) -> tuple[pd.DataFrame, np.ndarray]:
    """A continuous record (``Time [s]``, ``Position [mm]`` falling into the specimen, ``Force [N]``
    negative in compression) whose holds carry exactly the hold readings of ``force`` (step,
    time_s, force_mN); between holds the stage moves for ``move_s``. Returns the record and the
    holds' (start, end) times."""
    rng = np.random.default_rng(seed)
    t, p, f, windows = [], [], [], []
    now = 0.0
    for s in np.arange(0.0, pre_s, dt):  # at contact, before step 1
        t.append(now + s), p.append(position0), f.append(noise * rng.standard_normal())
    now += pre_s
    depth_prev = 0.0
    for k, g in force.groupby("step"):
        depth = k * step_size
        for s in np.arange(dt, move_s, dt):  # moving
            t.append(now + s), p.append(position0 - (depth_prev + (depth - depth_prev) * s / move_s))
            f.append(float(g["force_mN"].iloc[0]) * s / move_s)
        now += move_s
        start = now
        for tt, ff in zip(g["time_s"], g["force_mN"], strict=True):
            t.append(now + tt), p.append(position0 - depth), f.append(ff)
        windows.append((start, now + float(g["time_s"].max())))
        now += float(g["time_s"].max()) + dt
        depth_prev = depth
    scale = 1e-3 if newtons else 1.0
    record = pd.DataFrame(
        {
            "Time [s]": t,
            "Position [mm]": p,
            ("Force [N]" if newtons else "Force [mN]"): -np.asarray(f) * scale,
        }
    )
    return record, np.array(windows)


def sampled_record(
    rate_hz: float,
    steps: int = 6,
    step_size: float = 0.5,
    hold_s: float = 30.0,
    ramps_s: tuple[float, ...] = (0.5, 1.0, 1.5, 2.0),
    mu_kPa: float = 4.0,
    radius: float = 4.77,
    tau_s: float = 4.0,
    relax: float = 0.3,
    noise: float = 0.0,
    position_noise_mm: float = 0.0,
    drift_mN_per_s: float = 0.0,
    approach_mm: float = 1.0,
    wait_s: float = 10.0,
    position0: float = 37.5,
    seed: int = 0,
) -> tuple[pd.DataFrame, np.ndarray]:
    """A load-frame record sampled at ``rate_hz`` as a lab's would be: the stage approaches from
    ``approach_mm`` above the specimen, waits at contact, then each step's ramp (``ramps_s`` in
    turn) and a hold whose force relaxes by eq. 9 to F_k = 16/3 mu sqrt(R) d^1.5 (plus
    ``relax`` F_k at the stop, time constant ``tau_s``), then withdraws above the contact and
    waits. ``noise`` is the force noise's standard deviation relative to step 1's F, absolute
    and the same on every reading; the load cell drifts linearly from 0 at t = 0. Columns
    ``Time [s]``, ``Position [mm]`` (falling into the specimen), ``Force [N]`` (negative in
    compression). Returns the record and the true static forces F_k (mN)."""
    rng = np.random.default_rng(seed)
    dt = 1.0 / rate_hz
    F = 16.0 / 3.0 * mu_kPa * np.sqrt(radius) * (step_size * np.arange(1, steps + 1)) ** 1.5
    pieces = []  # (duration, depth(s), force(s)) with s the time from the piece's start
    approach_s = approach_mm / 0.5
    pieces.append((approach_s, lambda s: -approach_mm + 0.5 * s, lambda s: 0.0 * s))
    pieces.append((wait_s, lambda s: 0.0 * s, lambda s: 0.0 * s))
    f_prev, d_prev = 0.0, 0.0
    for k in range(steps):
        ramp = ramps_s[k % len(ramps_s)]
        d_k, peak = step_size * (k + 1), F[k] * (1.0 + relax)
        pieces.append(
            (
                ramp,
                lambda s, a=d_prev, b=d_k, r=ramp: a + (b - a) * s / r,
                lambda s, a=f_prev, b=peak, r=ramp: a + (b - a) * s / r,
            )
        )
        pieces.append(
            (hold_s, lambda s, d=d_k: d + 0.0 * s, lambda s, f=F[k]: f * (1.0 + relax * np.exp(-s / tau_s)))
        )
        f_prev, d_prev = F[k] * (1.0 + relax * np.exp(-hold_s / tau_s)), d_k
    pieces.append(
        (
            2.0,
            lambda s, a=d_prev: a - (a + approach_mm) * s / 2.0,
            lambda s, a=f_prev: a * (1 - s / 0.5) * (s < 0.5),
        )
    )
    pieces.append((wait_s, lambda s: -approach_mm + 0.0 * s, lambda s: 0.0 * s))
    total = sum(p[0] for p in pieces)
    t = np.arange(0.0, total, dt)
    depth, force = np.zeros_like(t), np.zeros_like(t)
    start = 0.0
    for duration, d_of, f_of in pieces:
        sel = (t >= start - 1e-9 * dt) & (t < start + duration - 1e-9 * dt)
        depth[sel], force[sel] = d_of(t[sel] - start), f_of(t[sel] - start)
        start += duration
    force = force + drift_mN_per_s * t + noise * F[0] * rng.standard_normal(len(t))
    depth = depth + position_noise_mm * rng.standard_normal(len(t))
    record = pd.DataFrame({"Time [s]": t, "Position [mm]": position0 - depth, "Force [N]": -force * 1e-3})
    return record, F


def write_bluehill(path: Path, record: pd.DataFrame, encoding: str = "utf-8") -> Path:
    """An Instron Bluehill style export of a record (``Time [s]``, ``Position [mm]``, ``Force
    [N]``): a block of test information, a blank line, the quoted column names ``Time``,
    ``Extension``, ``Load`` and a unit row ``(s)``, ``(mm)``, ``(N)``; every value quoted."""
    lines = [
        '"Sample ID:","Specimen 1"',
        '"Test date:","25/11/2026"',
        '"Method:","Indentation steps.im_cmp"',
        '"Operator:","lab"',
        '"Specimen label:","phantom A"',
        "",
        '"Time","Extension","Load"',
        '"(s)","(mm)","(N)"',
    ]
    t, p, f = (record[c].to_numpy() for c in ("Time [s]", "Position [mm]", "Force [N]"))
    lines += [f'"{a:.5f}","{b:.6f}","{c:.8f}"' for a, b, c in zip(t, p, f, strict=True)]
    path.write_text("\r\n".join(lines) + "\r\n", encoding=encoding, newline="")
    return path


def write_testsuite(path: Path, record: pd.DataFrame) -> Path:
    """An MTS TestSuite (TW) style export: tab separated, a header block of ``Name:<TAB>value``
    lines, the column names ``Running Time``, ``Crosshead``, ``Axial Force`` and a bare unit row
    ``sec``, ``mm``, ``kN``."""
    lines = [
        "Test Run Name:\tRun 3",
        "Test Definition:\tIndentation steps",
        "Specimen:\tphantom A",
        "Station:\tLoad frame 2",
        "",
        "Running Time\tCrosshead\tAxial Force",
        "sec\tmm\tkN",
    ]
    t, p, f = (record[c].to_numpy() for c in ("Time [s]", "Position [mm]", "Force [N]"))
    lines += [f"{a:.5f}\t{b:.6f}\t{c * 1e-3:.11f}" for a, b, c in zip(t, p, f, strict=True)]
    path.write_text("\n".join(lines) + "\n")
    return path


def add_matchid_tensors(folder: Path) -> Path:
    """MatchID's deformation-gradient columns ``defgradient.F[0,0] [-]`` .. (commas inside the
    brackets, unquoted, as MatchID writes them) added to every file of an export folder, between
    its columns."""
    names = [f"defgradient.F[{i},{j}] [-]" for i in range(3) for j in range(3)]
    for path in sorted(folder.glob("*.csv")):
        table = pd.read_csv(path)
        head = list(table.columns[:5])
        tail = list(table.columns[5:])
        rows = [",".join(head + names + tail)]
        eye = np.eye(3).ravel()
        for values in table.itertuples(index=False):
            v = list(values)
            rows.append(
                ",".join(
                    [f"{x:.10E}" for x in v[:5]] + [f"{x:.4f}" for x in eye] + [f"{x:.10E}" for x in v[5:]]
                )
            )
        path.write_text("\n".join(rows) + "\n")
    return folder
