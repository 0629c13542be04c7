"""Log-log figure of the fitted c5's distance to the finest level against the cell size, at every
point of verification studies (one panel per study, e.g. one per radius), with the observed order
of each point's finest triplet in the legend (docs/validation/verification.md). A panel may be a
glob: a study made a point at a time, its files merged (``inference.merge_verification_studies``).

    .venv/bin/python docs/figures/verification_c5.py docs/validation/data/verification-fit-R4.77.json \
        docs/validation/data/verification-fit-R8.json --out docs/validation/figures/verification-c5.png
    .venv/bin/python docs/figures/verification_c5.py \
        "docs/validation/data/verification-contact-L4-R4.77-*.json" \
        docs/validation/data/verification-contact-L4-R8.json --out docs/validation/figures/verification-c5-L4.png
"""

from __future__ import annotations

import argparse
import glob
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from indentation_studio.inference.budgets.study_files import (
    load_verification_study,
    merge_verification_studies,
)


def panel_study(pattern: str) -> dict:
    """The study of one panel: a file, or the files a glob names merged into one."""
    paths = sorted(glob.glob(pattern))
    if not paths:
        raise SystemExit(f"no verification study matches {pattern!r}")
    return load_verification_study(paths[0]) if len(paths) == 1 else merge_verification_studies(paths)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("studies", nargs="+", help="study files or globs (one panel each)")
    ap.add_argument("--quantity", default="fit c5")
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    fig, axes = plt.subplots(1, len(args.studies), figsize=(6.2 * len(args.studies), 4.6), squeeze=False)
    for ax, path in zip(axes[0], args.studies, strict=True):
        study = panel_study(path)
        reading = study["inputs"].get("reading", "paper")
        for case in study["cases"]:
            q = case["quantities"][args.quantity]
            v = np.asarray(q["values"], float)
            h = np.asarray([lv["h_mm"] for lv in case["levels"]], float)
            err = 100.0 * np.abs(v[1:] / v[0] - 1.0)
            orders = ", ".join(f"{p:.2g}" for p in q["orders"])
            label = f"{case['theta'][0]:g}, {case['theta'][1]:g} (p = {orders})"
            ax.loglog(h[1:], np.maximum(err, 1e-3), "o-", label=label)
        hh = np.array([h[1:].min(), h[1:].max()])
        for p, style in ((1, ":"), (2, "--")):
            ax.loglog(hh, 2.0 * (hh / hh[0]) ** p, "k" + style, lw=0.8, label=f"order {p}")
        ax.set_xlabel("cell size h = (V / N)^(1/3), mm")
        ax.set_ylabel(f"|{args.quantity} / finest level's - 1|, %")
        radius = study["cases"][0]["radius"]
        ax.set_title(f"R = {radius:g} mm, {study['family']['name']}, objective '{reading}'", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=6.5, title="(c1, c5) kPa, observed orders", title_fontsize=7)
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=130)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
