"""Read published MatchID exports with the studio's reader (docs/validation/experiments.md): the
tension test in SolavLab/DuoDIC (Apache-2.0, not in this repository) at commit 5200f02.

    git clone https://github.com/SolavLab/DuoDIC && git -C DuoDIC checkout 5200f02
    .venv/bin/python benchmarks/probes/matchid_published_exports.py DuoDIC/MatchID_data/tension

Prints what ``inference.lab.matchid_export.read_matchid`` makes of the folder: the frames, the
points correlated in each, how well the reference positions agree across images (coor - disp) and
the range of each displacement component over all frames.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from indentation_studio.inference.lab.matchid_export import read_matchid


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("folder", type=Path, help="a folder of MatchID CSV exports, one per image")
    args = ap.parse_args()
    dic = read_matchid(args.folder)
    counts = dic.points_per_frame
    print(
        f"{len(dic.frame_ids)} frames ({dic.frame_ids.min()}..{dic.frame_ids.max()}), {len(dic.xyz)} points"
    )
    print(f"points per frame: {counts.min()} to {counts.max()}")
    for note in dic.notes:
        print(note)
    for j, name in enumerate("UVW"):
        print(f"{name}: {np.nanmin(dic.u[..., j]):.4g} .. {np.nanmax(dic.u[..., j]):.4g} mm")


if __name__ == "__main__":
    main()
