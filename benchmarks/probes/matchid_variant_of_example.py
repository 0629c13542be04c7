"""The shipped example as a lab's files, imported and checked (docs/validation/experiments.md): the
experiment ``examples/synthetic-12-250`` written as a MatchID export folder and a continuous
load-frame record in newtons, as ``tests/test_lab_importers.py`` writes its lab files (with the
writers of ``tests/lab_files.py``), then imported and checked with the studio's commands.

    .venv/bin/python benchmarks/probes/matchid_variant_of_example.py [--out runs/matchid-variant]

The DIC: the reference frame, then two frames per step (mid-hold at 0.97 of the step's field, and
0.5 s before the hold ends), 4 % of the points lost at random in each step (seed 0), the frames'
times in ``frame_times.csv``. The record: the holds' readings of ``force.csv`` with 2 s moves
between them and 20 s at contact before step 1. Then, printed with their JSON output:

    indent-studio check --experiment examples/synthetic-12-250 --out OUT/check-example
    indent-studio import matchid --dic OUT/matchid --load-frame OUT/record.csv \\
        --frame-times OUT/frame_times.csv --indenter examples/synthetic-12-250/indenter.csv \\
        --indenter-unit mm --radius 4.77 --step-size 0.5 --steps 28 --fiber-angle 60 --out OUT/imported
    indent-studio check --experiment OUT/imported

and a comparison of the two checks (static forces, registration, noise, points, warnings).
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))

from lab_files import load_frame_record, write_matchid  # noqa: E402

from indentation_studio.inference import load_experiment  # noqa: E402

EXAMPLE = ROOT / "examples" / "synthetic-12-250"
LOST = 0.04


def studio(*args: str) -> dict:
    """One ``indent-studio`` command with ``--json``: its JSON object (the command echoed first)."""
    print("indent-studio " + " ".join(args))
    cli = [sys.executable, "-m", "indentation_studio.studio.cli", *args, "--json"]
    return json.loads(subprocess.run(cli, capture_output=True, text=True, check=True).stdout)


def write_lab_files(out: Path) -> None:
    """The example's DIC as a MatchID folder (with frame times) and its force as a load-frame record."""
    exp = load_experiment(EXAMPLE)
    u = exp.dic_u.copy()
    u[np.random.default_rng(0).random(u.shape[:2]) < LOST] = np.nan
    record, windows = load_frame_record(pd.read_csv(EXAMPLE / "force.csv"), exp.step_size)
    record.to_csv(out / "record.csv", index=False)
    frames, times = [np.zeros_like(u[0])], [5.0]
    for k in range(len(u)):
        frames += [0.97 * u[k], u[k]]
        times += [windows[k].mean(), windows[k][1] - 0.5]
    write_matchid(out / "matchid", exp.dic_xyz, np.stack(frames))
    pd.DataFrame({"frame": np.arange(len(times)), "time [s]": times}).to_csv(
        out / "frame_times.csv", index=False
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=Path("runs/matchid-variant"))
    args = ap.parse_args()
    out = args.out
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    write_lab_files(out)
    example = studio("check", "--experiment", str(EXAMPLE), "--out", str(out / "check-example"))
    imported = studio(
        *("import", "matchid", "--dic", str(out / "matchid"), "--load-frame", str(out / "record.csv")),
        *("--frame-times", str(out / "frame_times.csv"), "--indenter", str(EXAMPLE / "indenter.csv")),
        *("--indenter-unit", "mm", "--radius", "4.77", "--step-size", "0.5", "--steps", "28"),
        *("--fiber-angle", "60", "--out", str(out / "imported")),
    )
    print(f"frames of the steps: {imported['frames']}")
    check = studio("check", "--experiment", str(out / "imported"))
    f_ex = np.array([h["f_inf_mN"] for h in example["holds"]])
    f_im = np.array([h["f_inf_mN"] for h in check["holds"]])
    print(f"f_inf: largest |imported - example| {np.abs(f_im - f_ex).max():.2g} mN over {len(f_ex)} holds")
    for name, c in (("example", example), ("imported", check)):
        tau, left = [h["tau_s"] for h in c["holds"]], [h["unrelaxed_pct"] for h in c["holds"]]
        print(f"{name}: tau {min(tau):.2f} to {max(tau):.2f} s, at most {max(left):.2f} % of f_inf unrelaxed")
    for key in ("indentation_point_mm", "sphere_radius_mm", "fiber_angle_from_strain_deg", "dic_noise_mm"):
        print(
            f"{key}: example {np.round(example[key], 4).tolist()}, imported {np.round(check[key], 4).tolist()}"
        )
    for name, c in (("example", example), ("imported", check)):
        print(
            f"{name}: {c['points']} points, {c['points_every_step']} at every step, {len(c['warnings'])} warnings"
        )
        for w in c["warnings"]:
            print(f"  warning: {w}")


if __name__ == "__main__":
    main()
