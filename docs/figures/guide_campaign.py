"""The figure of the campaign guide (docs/guide/campaign.md): a small campaign over the paper's box on
the coarse mesh, run with the guide's command, its design coloured by each point's wall time and the
force against depth of the points at the box's corners and centre (``ins.figures.campaign_figure``).

    .venv/bin/python docs/figures/guide_campaign.py [--runs-dir runs] [--out docs/guide/figures/campaign.png]

Runs (or resumes: a finished campaign is only checked and drawn)

    indent-studio campaign run --name guide-coarse --grid c1=1:21:5,c5=82.5:578:5 --mesh coarse --jobs 2

(25 points, the paper's protocol: 28 steps of 0.5 mm, R = 4.77 mm), then prints its summary and
writes the figure.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

from indentation_studio.campaign import load_campaign, open_campaign
from indentation_studio.studio.figures import campaign_figure, save_figure

ROOT = Path(__file__).resolve().parents[2]
NAME, GRID = "guide-coarse", "c1=1:21:5,c5=82.5:578:5"
COMMAND = ["campaign", "run", "--name", NAME, "--grid", GRID, "--mesh", "coarse", "--jobs", "2"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs-dir", type=Path, default=Path("runs"))
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "guide" / "figures" / "campaign.png")
    args = ap.parse_args()
    cli = [sys.executable, "-m", "indentation_studio.studio.cli"]
    run = subprocess.run(
        [*cli, *COMMAND, "--runs-dir", str(args.runs_dir), "--json"],
        capture_output=True,
        text=True,
        check=True,
    )
    summary = json.loads(run.stdout)
    print("indent-studio " + " ".join(COMMAND))
    print({k: summary[k] for k in ("done", "failed", "pending", "solved_now")})
    index = open_campaign(NAME, runs_dir=args.runs_dir).index
    done = index[index["status"].astype(str) == "done"]
    print(
        f"wall time per point: {done['wall_s'].min():.2f} to {done['wall_s'].max():.2f} s, "
        f"total {done['wall_s'].sum():.1f} s"
    )
    data = load_campaign(NAME, runs_dir=args.runs_dir)
    fig = campaign_figure(
        index,
        data,
        title=f"campaign {NAME}: {GRID} on the coarse mesh, 28 x 0.5 mm, R = 4.77 mm, --jobs 2",
    )
    args.out.parent.mkdir(parents=True, exist_ok=True)
    print(save_figure(fig, args.out, dpi=110))


if __name__ == "__main__":
    main()
