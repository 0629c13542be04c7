"""The cases of issue 47 ("a lab user's first hour"), run as a user would, with their exit codes
and messages: run it on a checkout before and after a change to compare.

    .venv/bin/python benchmarks/first_hour_cases.py --work runs/first-hour [--studio ".venv/bin/indent-studio"]

``--studio`` is the command that runs the command line (split as a shell would); for a commit's,
a script that puts that commit's tree in front of the installed one.

It writes its inputs under ``--work`` (from ``examples/`` and the synthetic records of
``benchmarks/contact_detection_table.py``) and prints, for each case, the command, its exit code
and the last lines it printed.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).parent))
from contact_detection_table import synthetic_record

LAB = Path("examples/lab-matchid")


def _european(frame: pd.DataFrame, path: Path) -> Path:
    """``frame`` as a German-settings export writes it: ';' between fields, ',' for decimals."""
    frame.to_csv(path, sep=";", decimal=",", index=False)
    return path


def inputs(work: Path) -> dict[str, Path]:
    """The files of the cases, written under ``work``."""
    if work.exists():
        shutil.rmtree(work)
    work.mkdir(parents=True)
    files = {}
    record, _ = synthetic_record("preload", 1.0, 40)
    files["preload"] = work / "preload-1hz-40steps.csv"
    record.to_csv(files["preload"], index=False)
    files["euro_units"] = _european(record, work / "euro-units.csv")
    at_contact, _ = synthetic_record("contact", 1.0, 40)
    files["contact"] = work / "contact-1hz-40steps.csv"
    at_contact.to_csv(files["contact"], index=False)
    plain = record.rename(columns={"Time [s]": "Time", "Position [mm]": "Position", "Force [N]": "Force"})
    files["euro_plain"] = _european(plain, work / "euro-plain.csv")
    # frames on the load frame's clock, each taken 0.5 s before its hold began (during the ramp)
    holds = np.array([[13.0 + 11.0 * k, 23.0 + 11.0 * k] for k in range(28)])
    times = pd.DataFrame({"Frame": np.arange(29), "Time [s]": np.concatenate([[2.0], holds[:, 0] - 0.5])})
    files["ramp_times"] = work / "frame_times_on_ramps.csv"
    times.to_csv(files["ramp_times"], index=False)
    # an experiment folder whose force.csv is European
    exp = work / "euro-experiment"
    shutil.copytree("examples/synthetic-12-250", exp)
    _european(pd.read_csv(exp / "force.csv"), exp / "force.csv")
    files["euro_experiment"] = exp
    # a MatchID folder with NaN rows in one frame, and one with a frame missing
    nan = work / "matchid-nan"
    shutil.copytree(LAB / "matchid", nan)
    f = nan / "Image_0005_0.tiff.csv"
    lines = f.read_text().splitlines()
    cells = lines[10].split(",")
    lines[10] = ",".join(cells[:2] + ["NaN"] * 6 + cells[8:])
    f.write_text("\n".join(lines) + "\n")
    files["matchid_nan"] = nan
    gap = work / "matchid-gap"
    shutil.copytree(LAB / "matchid", gap)
    (gap / "Image_0007_0.tiff.csv").unlink()
    files["matchid_gap"] = gap
    return files


def cases(files: dict[str, Path], work: Path) -> list[tuple[str, list[str]]]:
    lab = [
        "--load-frame",
        str(LAB / "load_frame.csv"),
        "--indenter",
        str(LAB / "indenter.csv"),
        "--radius",
        "4.77",
        "--step-size",
        "0.5",
        "--steps",
        "28",
    ]
    record = ["--radius", "4.77", "--step-size", "0.5", "--steps", "40"]
    return [
        (
            "record at contact with a preload, 1 Hz, 40 steps",
            [
                "import",
                "load-frame",
                "--record",
                str(files["preload"]),
                *record,
                "--out",
                str(work / "f1.csv"),
            ],
        ),
        (
            "record at contact without a preload, 1 Hz, 40 steps",
            [
                "import",
                "load-frame",
                "--record",
                str(files["contact"]),
                *record,
                "--out",
                str(work / "f0.csv"),
            ],
        ),
        (
            "clock offset: frames on the load frame's clock, taken during the ramps",
            [
                "import",
                "matchid",
                "--dic",
                str(LAB / "matchid"),
                "--frame-times",
                str(files["ramp_times"]),
                *lab,
                "--out",
                str(work / "exp-ramps"),
            ],
        ),
        (
            "European load-frame record, units in the header",
            [
                "import",
                "load-frame",
                "--record",
                str(files["euro_units"]),
                *record,
                "--out",
                str(work / "f2.csv"),
            ],
        ),
        (
            "European load-frame record, no units in the header",
            [
                "import",
                "load-frame",
                "--record",
                str(files["euro_plain"]),
                *record,
                "--force-unit",
                "N",
                "--position-unit",
                "mm",
                "--time-unit",
                "s",
                "--out",
                str(work / "f3.csv"),
            ],
        ),
        (
            "European force.csv in an experiment folder",
            ["check", "--experiment", str(files["euro_experiment"])],
        ),
        ("fit without arguments", ["fit"]),
        ("a mistyped command", ["fitt"]),
        (
            "a frame missing from a MatchID folder",
            [
                "import",
                "matchid",
                "--dic",
                str(files["matchid_gap"]),
                "--frame-times",
                str(LAB / "frame_times.csv"),
                *lab,
                "--out",
                str(work / "exp-gap"),
            ],
        ),
        (
            "MatchID import with NaN rows in a frame, fiber angle typed in the camera's frame",
            [
                "import",
                "matchid",
                "--dic",
                str(files["matchid_nan"]),
                "--frame-times",
                str(LAB / "frame_times.csv"),
                *lab,
                "--fiber-angle",
                "120.48",
                "--time-offset",
                "-23.6",
                "--out",
                str(work / "exp-lab"),
            ],
        ),
        ("check of that import", ["check", "--experiment", str(work / "exp-lab"), "--mesh", "coarse"]),
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--work", type=Path, default=Path("runs/first-hour"))
    parser.add_argument("--studio", default=str(Path(sys.executable).parent / "indent-studio"))
    parser.add_argument("--lines", type=int, default=6, help="last lines of output shown per case")
    args = parser.parse_args()
    files = inputs(args.work)
    for title, argv in cases(files, args.work):
        run = subprocess.run(
            [*shlex.split(args.studio), *argv],
            capture_output=True,
            text=True,
            env={**os.environ, "COLUMNS": "120"},
        )
        out = (run.stdout + run.stderr).strip().splitlines()
        print(f"## {title}\n$ indent-studio {' '.join(argv)}\nexit {run.returncode}")
        for line in out[-args.lines :]:
            print(f"  {line[:400]}")
        meta = Path(argv[argv.index("--out") + 1]) / "experiment.json" if "--out" in argv else None
        if meta is not None and meta.is_file():
            clock = json.loads(meta.read_text())["imported"].get("clock_offset") or {}
            print(
                f"  experiment.json clock_offset: { ({k: clock.get(k) for k in ('offset_s', 'low_s', 'high_s', 'source')}) }"
            )
        print()
    help_text = subprocess.run(
        [*shlex.split(args.studio), "fit", "--help"], capture_output=True, text=True
    ).stdout
    print(
        f"## fit --help: {help_text.count('``')} double backticks, README pointers: {help_text.count('README')}"
    )


if __name__ == "__main__":
    main()
