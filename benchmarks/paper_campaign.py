"""Benchmark (by hand): the paper's 775-point campaign on the embedded solver.

R = 4.77 mm, 28 x 0.5 mm, default mesh, ``--jobs`` processes. Runs ``indent-studio campaign run``
into a fresh store (``runs/<name>``, removed first unless ``--resume``), then prints the wall time,
failed points, the store's size on disk and the slowest points from ``index.parquet``.

    .venv/bin/python benchmarks/paper_campaign.py [--name bench-paper] [--jobs 2] [--radius 4.77]
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd


def folder_size_mb(root: Path) -> float:
    return sum(p.stat().st_size for p in root.rglob("*") if p.is_file()) / 1e6


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--name", default="bench-paper")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--radius", type=float, default=4.77)
    ap.add_argument("--grid", default="paper")
    ap.add_argument("--resume", action="store_true", help="keep what an earlier run finished")
    args = ap.parse_args()
    root = Path("runs") / args.name
    if root.exists() and not args.resume:
        shutil.rmtree(root)
    exe = Path(sys.executable).with_name("indent-studio")
    cmd = [
        str(exe),
        "campaign",
        "run",
        "--name",
        args.name,
        "--grid",
        args.grid,
        "--radius",
        str(args.radius),
    ]
    cmd += ["--jobs", str(args.jobs), "--json"]
    t0 = time.perf_counter()
    out = subprocess.run(cmd, capture_output=False, stdout=subprocess.PIPE, text=True, check=False)
    wall = time.perf_counter() - t0
    summary = json.loads(out.stdout.strip().splitlines()[-1])
    index = pd.read_parquet(root / "index.parquet")
    done = index[index["status"] == "done"]
    slow = done.sort_values("wall_s", ascending=False).head(8)
    print(f"command: {' '.join(cmd)}")
    print(f"wall time {wall:.0f} s ({wall / 60:.1f} min); campaign says {summary}")
    print(f"points done {len(done)}, failed {int((index['status'] == 'failed').sum())}")
    print(f"store size {folder_size_mb(root):.1f} MB ({root})")
    print(
        f"per-point wall time: median {done['wall_s'].median():.2f} s, mean {done['wall_s'].mean():.2f} s, "
        f"max {done['wall_s'].max():.2f} s; Newton iterations median {done['newton_iterations'].median():.0f}"
    )
    print("slowest points:")
    print(slow[["point", "c1", "c5", "wall_s", "newton_iterations"]].to_string(index=False))
    failed = index[index["status"] == "failed"]
    if len(failed):
        print("failed points:")
        print(failed[["point", "c1", "c5", "error"]].to_string(index=False))


if __name__ == "__main__":
    main()
