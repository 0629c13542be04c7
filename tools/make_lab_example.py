"""Write the lab example (``examples/lab-matchid``): a day's files of a lab, made by the studio's own
model so that they may be redistributed.

    .venv/bin/python tools/make_lab_example.py --out examples/lab-matchid \\
        --from-run L4-R4.77-12-250.npz

The studio's model (the paper's protocol: R = 4.77 mm, 28 steps of 0.5 mm) at (c1, c5) = (12, 250)
kPa, solved on ``default`` or read from a stored run (``--from-run``: the example in the repository
is a contact-L4 run with the surface stick, ``indent-studio simulate --mesh contact-L4 --c1 12
--c5 250 --radius 4.77``, the model converged within what the study measured: docs/validation/
verification.md), recorded as a lab records it:

* ``matchid/``: a MatchID export, one CSV per image (``Image_NNNN_0.tiff.csv``; headers
  ``category.Long name [unit]``, unquoted ``defgradient.F[0,0] [-]`` with commas in the
  brackets), in the *cameras'* coordinates: the specimen's face tilted 12 degrees and facing the
  camera (its normal along the camera's -z), 310 mm away; the points on a 20-pixel grid of the
  reference image (a pinhole camera, 4,000 px focal length), 0.01 mm noise, about 2 % of the points
  lost in each image, those under the indenter (inside its contact circle, or its equator once
  deeper than R) not seen; image 0 the reference, then one image
  late in each hold;
* ``frame_times.csv``: the images' time stamps on the cameras' clock, which started 23.6 s before
  the load frame's (the import finds the offset, -23.6 s, from the data);
* ``load_frame.csv``: the load frame's record at 100 Hz in an Instron Bluehill layout (a header
  block, the column names, a unit row, every value quoted): the stage approaches from 1 mm
  above, waits at contact, then each step's 1 s ramp and a 10 s hold (the paper's are 30 s:
  shorter here to keep the file small) in which the force relaxes by eq. 9 to the model's
  force, 0.5 % noise (of step 1's force), a load cell drifting 0.01 mN/s, a spike of +0.3 N in
  one reading before contact, and the withdrawal;
* ``indenter.csv``: 400 points tracked on the indenter's cap (camera coordinates);
* ``lab.json``: how it was made and the protocol to declare (the fiber angle as the camera sees
  it).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pandas as pd

from indentation_studio.forward.convergence.mesh_study import top_field_interpolator
from indentation_studio.forward.fe_predictor import FESolverPredictor
from indentation_studio.forward.result import SimulationResult
from indentation_studio.forward.spec import ModelSpec

THETA = (12.0, 250.0)
FIBER_DEG = 60.0  # the fibers in the specimen's face, from its x axis
TILT_DEG = 12.0
TILT_AXIS = np.array([np.cos(np.radians(-35.0)), np.sin(np.radians(-35.0)), 0.0])
STANDOFF = np.array([-4.0, 6.0, 310.0])  # the indentation point in camera coordinates, mm
FOCAL_PX, CENTRE_PX, GRID_PX = 4000.0, 1024.0, 20
FOV_MM = 25.0
DIC_NOISE_MM = 0.01
HOLD_S, RAMP_S, RATE_HZ = 10.0, 1.0, 100.0
FORCE_NOISE, DRIFT_MN_S, SPIKE_N = 0.005, 0.01, 0.3
CLOCK_AHEAD_S = 23.6  # the cameras' clock started this long before the load frame's


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    k = axis / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


#: specimen frame -> camera frame: the face turned to the camera (a half turn about x), then tilted
R_CAM = _rotation(TILT_AXIS, np.radians(TILT_DEG)) @ np.diag([1.0, -1.0, -1.0])


def _grid_points(radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Points of the face on a pixel grid of the reference image (the indentation point's image
    at the centre): their specimen-frame positions (n, 3) and pixel positions (n, 2)."""
    n = R_CAM @ [0.0, 0.0, 1.0]
    half = int(FOV_MM * FOCAL_PX / STANDOFF[2] / GRID_PX) + 2
    px = np.arange(-half, half + 1) * GRID_PX + CENTRE_PX
    gx, gy = np.meshgrid(px, px)
    pix = np.column_stack([gx.ravel(), gy.ravel()]).astype(float)
    c0 = np.array([STANDOFF[0] / STANDOFF[2] * FOCAL_PX, STANDOFF[1] / STANDOFF[2] * FOCAL_PX])
    rays = np.column_stack([(pix - CENTRE_PX + c0) / FOCAL_PX, np.ones(len(pix))])  # camera rays
    s = (STANDOFF @ n) / (rays @ n)  # where each ray meets the face
    cam = rays * s[:, None]
    xyz = (cam - STANDOFF) @ R_CAM  # specimen frame (z = 0 on the face)
    r = np.hypot(xyz[:, 0], xyz[:, 1])
    keep = (r > radius) & (r < FOV_MM)
    return xyz[keep], pix[keep]


def _record(force: np.ndarray, step_size: float, rng: np.random.Generator) -> pd.DataFrame:
    """The load frame's 100 Hz record (module docstring): time, position (falling into the
    specimen from 37.5 mm at contact), force in N (negative in compression)."""
    steps = len(force)
    pieces = [
        (2.0, lambda s: -1.0 + 0.5 * s, lambda s: 0.0 * s),
        (10.0, lambda s: 0.0 * s, lambda s: 0.0 * s),
    ]
    f_prev, d_prev = 0.0, 0.0
    for k in range(steps):
        d_k, peak = step_size * (k + 1), force[k] * 1.3
        pieces.append(
            (
                RAMP_S,
                lambda s, a=d_prev, b=d_k: a + (b - a) * s / RAMP_S,
                lambda s, a=f_prev, b=peak: a + (b - a) * s / RAMP_S,
            )
        )
        pieces.append(
            (HOLD_S, lambda s, d=d_k: d + 0.0 * s, lambda s, f=force[k]: f * (1.0 + 0.3 * np.exp(-s / 3.0)))
        )
        f_prev, d_prev = force[k] * (1.0 + 0.3 * np.exp(-HOLD_S / 3.0)), d_k
    pieces.append(
        (
            3.0,
            lambda s, a=d_prev: a - (a + 1.0) * s / 3.0,
            lambda s, a=f_prev: a * np.clip(1 - s / 1.5, 0, 1) ** 2,
        )
    )
    pieces.append((10.0, lambda s: -1.0 + 0.0 * s, lambda s: 0.0 * s))
    t = np.arange(0.0, sum(p[0] for p in pieces), 1.0 / RATE_HZ)
    depth, f = np.zeros_like(t), np.zeros_like(t)
    start = 0.0
    for duration, d_of, f_of in pieces:
        sel = (t >= start - 1e-9) & (t < start + duration - 1e-9)
        depth[sel], f[sel] = d_of(t[sel] - start), f_of(t[sel] - start)
        start += duration
    f = f + DRIFT_MN_S * t + FORCE_NOISE * force[0] * rng.standard_normal(len(t))
    f[int(7.3 * RATE_HZ)] += SPIKE_N * 1e3  # a load-cell spike before contact
    depth = depth + 2e-4 * rng.standard_normal(len(t))
    return pd.DataFrame({"t": t, "ext": 37.5 - depth, "load": -f * 1e-3}), pieces


def _hold_windows(pieces, steps: int) -> np.ndarray:
    """(start, end) of each hold on the load frame's clock: pieces 3, 5, ... (after the approach,
    the wait and each ramp)."""
    starts = np.cumsum([0.0] + [p[0] for p in pieces])
    return np.array([(starts[i], starts[i] + pieces[i][0]) for i in range(3, 3 + 2 * steps, 2)])


def write_bluehill(path: Path, record: pd.DataFrame) -> None:
    lines = [
        '"Sample ID:","Phantom A, indentation 1"',
        '"Test date:","25/11/2026"',
        '"Method:","Stepwise indentation 28 x 0.5 mm.im_cmp"',
        '"Indenter:","Sphere R 4.77 mm"',
        '"Data rate:","100 Hz"',
        "",
        '"Time","Extension","Load"',
        '"(s)","(mm)","(N)"',
    ]
    lines += [
        f'"{a:.2f}","{b:.4f}","{c:.5f}"'
        for a, b, c in zip(record["t"], record["ext"], record["load"], strict=True)
    ]
    path.write_text("\r\n".join(lines) + "\r\n", newline="")


def write_matchid(folder: Path, xyz_cam: np.ndarray, pix: np.ndarray, u_cam: np.ndarray, rng) -> None:
    """One MatchID CSV per image (``u_cam`` (images, points, 3), NaN: not correlated)."""
    folder.mkdir(parents=True, exist_ok=True)
    head = (
        "Coordinates.Image X [Pixel],Coordinates.Image Y [Pixel],coor.X [mm],coor.Y [mm],coor.Z [mm],"
        "disp.Horizontal Displacement U [mm],disp.Vertical Displacement V [mm],disp.Out-Of-Plane: W [mm],"
        "defgradient.F[0,0] [-],defgradient.F[1,1] [-],ext.Current Image [#]"
    )
    for image, u in enumerate(u_cam):
        ok = np.isfinite(u).all(axis=1)
        cur = xyz_cam + np.nan_to_num(u)
        rows = [head]
        order = rng.permutation(np.flatnonzero(ok))  # correlation order, not the points' order
        for i in order:
            stretch = 1.0 + rng.normal(0.0, 1e-3, 2)
            rows.append(
                f"{pix[i, 0]:.0f},{pix[i, 1]:.0f},{cur[i, 0]:.6E},{cur[i, 1]:.6E},{cur[i, 2]:.6E},"
                f"{u[i, 0]:.6E},{u[i, 1]:.6E},{u[i, 2]:.6E},{stretch[0]:.5f},{stretch[1]:.5f},{image}"
            )
        (folder / f"Image_{image:04d}_0.tiff.csv").write_text("\n".join(rows) + "\n")


def _model_run(path: str | None) -> tuple[np.ndarray, np.ndarray, np.ndarray, ModelSpec]:
    """The model's force (steps,), top field (steps, nodes, 3), top nodes and spec at THETA: solved
    on ``default``, or read from a stored run (checked to be at THETA, R = 4.77 mm, 28 x 0.5 mm)."""
    if path is None:
        spec = ModelSpec()
        pred = FESolverPredictor(spec).predict(np.array([THETA]))
        return pred.force[0], pred.displacement[0], pred.top_xyz, spec
    run = SimulationResult.load(path)
    spec = ModelSpec.from_dict(run.spec)
    wanted = (*THETA, 4.77, 28, 0.5)
    have = (
        spec.material.c1,
        spec.material.c5,
        spec.indenter.radius,
        spec.protocol.steps,
        spec.protocol.step_size,
    )
    if not np.allclose(have, wanted):
        raise SystemExit(f"{path}: (c1, c5, R, steps, step) = {have}, not {wanted}")
    steps = np.asarray(run.depth) > 0  # a run's first row is depth 0
    return run.force[steps], run.displacement[steps], run.top_xyz, spec


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="examples/lab-matchid")
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument(
        "--from-run",
        help="a stored simulation (.npz of indent-studio simulate) at (12, 250) kPa, R = 4.77 mm, 28 x 0.5 mm "
        "to record instead of solving on default (the example in the repository: a contact-L4 run)",
    )
    args = ap.parse_args()
    out = Path(args.out)
    rng = np.random.default_rng(args.seed)
    force, field, top, spec = _model_run(args.from_run)
    radius, step_size = spec.indenter.radius, spec.protocol.step_size
    # the surface field at the DIC points (the quarter model unfolded by symmetry), fibers at FIBER_DEG
    xyz, pix = _grid_points(radius)
    fib = np.radians(FIBER_DEG - 90.0)  # model +y (fibers) -> specimen direction FIBER_DEG
    Q = np.array([[np.cos(fib), -np.sin(fib), 0], [np.sin(fib), np.cos(fib), 0], [0, 0, 1]])
    xy_model = xyz[:, :2] @ Q[:2, :2]  # the points in the model frame
    interp = top_field_interpolator(top, np.moveaxis(field, 0, 1))
    half = top[:, :2].max(axis=0)
    u = np.moveaxis(interp(np.minimum(np.abs(xy_model), half)), 0, 1)  # (steps, points, 3)
    u[..., 0] *= np.sign(xy_model[:, 0])
    u[..., 1] *= np.sign(xy_model[:, 1])
    u = u @ Q.T  # the specimen's frame
    for k in range(len(force)):  # hidden under the indenter: inside its contact circle (its equator past R)
        d = step_size * (k + 1)
        a = radius if d >= radius else np.sqrt(2 * radius * d - d * d)
        u[k, np.hypot(*(xyz[:, :2] + u[k, :, :2]).T) < a] = np.nan
    u = u + DIC_NOISE_MM * rng.standard_normal(u.shape)
    u = np.concatenate([DIC_NOISE_MM * rng.standard_normal((1, *u.shape[1:])), u])  # image 0: reference
    u[1:][rng.random(u[1:].shape[:2]) < 0.02] = np.nan  # points lost in some images
    xyz_cam = xyz @ R_CAM.T + STANDOFF + DIC_NOISE_MM * rng.standard_normal(xyz.shape)
    write_matchid(out / "matchid", xyz_cam, pix, u @ R_CAM.T, rng)
    # the indenter's upper cap in the reference state, tracked as points
    a, b = 2 * np.pi * rng.random(400), np.arccos(rng.uniform(0.2, 1.0, 400))
    cap = radius * np.column_stack([np.sin(b) * np.cos(a), np.sin(b) * np.sin(a), 1.0 + np.cos(b)])
    cap = cap + 0.005 * rng.standard_normal(cap.shape)
    pd.DataFrame(cap @ R_CAM.T + STANDOFF, columns=["X [mm]", "Y [mm]", "Z [mm]"]).to_csv(
        out / "indenter.csv", index=False, float_format="%.5f"
    )
    record, pieces = _record(force, step_size, rng)
    write_bluehill(out / "load_frame.csv", record)
    windows = _hold_windows(pieces, len(force))
    times = np.concatenate([[7.0], windows[:, 1] - 1.5]) + CLOCK_AHEAD_S  # on the cameras' clock
    pd.DataFrame({"Frame": np.arange(len(times)), "Time [s]": np.round(times, 3)}).to_csv(
        out / "frame_times.csv", index=False
    )
    f = R_CAM @ [np.cos(np.radians(FIBER_DEG)), np.sin(np.radians(FIBER_DEG)), 0.0]
    seen_deg = float(np.degrees(np.arctan2(f[1], f[0])) % 180.0)
    about = {
        "made_by": "tools/make_lab_example.py (the studio's own model; redistributable)",
        "theta_kPa": list(THETA),
        "model": spec.to_dict(),
        "protocol": {"radius_mm": radius, "step_size_mm": step_size, "steps": len(force)},
        "fiber_angle_deg_as_the_camera_sees_it": round(seen_deg, 2),
        "fiber_angle_deg_in_the_face": FIBER_DEG,
        "camera": {
            "tilt_deg": TILT_DEG,
            "tilt_axis": TILT_AXIS.tolist(),
            "rotation_specimen_to_camera": R_CAM.tolist(),
            "indentation_point_mm": STANDOFF.tolist(),
            "dic_noise_mm": DIC_NOISE_MM,
            "points": len(xyz),
            "clock_offset_s": -CLOCK_AHEAD_S,  # added to the image times: the load frame's clock
        },
        "load_frame": {
            "rate_hz": RATE_HZ,
            "hold_s": HOLD_S,
            "ramp_s": RAMP_S,
            "force_noise_of_step1": FORCE_NOISE,
            "drift_mN_per_s": DRIFT_MN_S,
            "spike_N_at_s": [SPIKE_N, 7.3],
            "holds_s": windows.tolist(),
        },
        "static_force_mN": force.tolist(),
    }
    (out / "lab.json").write_text(json.dumps(about, indent=1) + "\n")
    size = sum(p.stat().st_size for p in out.rglob("*") if p.is_file())
    print(f"wrote {out}: {len(xyz)} DIC points, {len(u)} images, {len(record)} readings, {size / 1e6:.2f} MB")


if __name__ == "__main__":
    main()
