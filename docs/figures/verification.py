"""The verification study's convergence, log-log: each quantity's distance to its extrapolated
value, |f_h - f_ext| / |f_ext|, against the cell size h, one line per material point, with the
observed order p of the finest triplet; one row per indenter radius.

    .venv/bin/python docs/figures/verification.py                       # both figures below
    .venv/bin/python docs/figures/verification.py --study baseline      # one of them

Reads the stored studies (docs/validation/data/verification-*.json, written by
``indent-studio verification-study``) and writes docs/validation/figures/verification-<study>.png.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.ticker import NullFormatter

DATA = Path(__file__).resolve().parents[1] / "validation" / "data"
OUT = Path(__file__).resolve().parents[1] / "validation" / "figures"

#: The studies drawn: name -> (title, the JSON files, each holding one or more cases).
STUDIES = {
    "baseline": (
        "Node-wise stick contact, family 8x8:1.2:1.5 (the baseline)",
        ["verification-baseline.json"],
    ),
    "surface1": (
        "Surface contact, one point per face (core8 family at R = 4.77 mm, 8x8:1.2:1.5 at R = 8 mm)",
        [
            "verification-core8-surface1-R4.77-3-540.json",
            "verification-core8-surface1-R4.77-11-330.json",
            "verification-core8-surface1-R4.77-19-120.json",
            "verification-surface1-R8.json",
        ],
    ),
}
QUANTITIES = ("force(14mm)", "uz(1R)", "fit c1", "fit c5")


def cases_of(files: list[str]) -> list[dict]:
    cases = []
    for name in files:
        cases += json.loads((DATA / name).read_text())["cases"]
    return cases


def convergence_figure(title: str, cases: list[dict]):
    radii = sorted({case["radius"] for case in cases})
    fig, axes = plt.subplots(
        len(radii), len(QUANTITIES), figsize=(2.8 * len(QUANTITIES), 2.7 * len(radii)), squeeze=False
    )
    for row, radius in zip(axes, radii, strict=True):
        at_radius = sorted((c for c in cases if c["radius"] == radius), key=lambda c: c["theta"][0])
        for ax, name in zip(row, QUANTITIES, strict=True):
            for colour, case in enumerate(at_radius):
                q = case["quantities"][name]
                h, f = np.asarray(q["sizes"], float), np.asarray(q["values"], float)
                ext, p = q["extrapolated"], q["orders"][0]
                err = np.abs(f - ext) / max(abs(ext), 1e-300)
                shown = err > 0
                c1, c5 = case["theta"]
                label = f"({c1:g}, {c5:g}): p = {p:.2f}" if p is not None else f"({c1:g}, {c5:g})"
                if not q["asymptotic"]:
                    label += " *"
                ax.loglog(h[shown], err[shown], "o-", color=f"C{colour}", ms=4, label=label)
            ax.xaxis.set_minor_formatter(NullFormatter())
            ax.set_xticks(h, [f"{x:.2g}" for x in h])
            ax.set_title(f"{name}, R = {radius:g} mm", fontsize=9)
            ax.set_xlabel("h (mm)", fontsize=8)
            ax.tick_params(labelsize=7)
            ax.legend(fontsize=7, title="(c1, c5) kPa", title_fontsize=7)
        row[0].set_ylabel("|f - f_ext| / |f_ext|", fontsize=8)
    fig.suptitle(title + "\n* not asymptotic: the two triplets' orders differ by more than 0.5", fontsize=9)
    fig.tight_layout()
    return fig


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--study", choices=sorted(STUDIES), action="append")
    args = parser.parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    for study in args.study or STUDIES:
        title, files = STUDIES[study]
        fig = convergence_figure(title, cases_of(files))
        path = OUT / f"verification-{study}.png"
        fig.savefig(path, dpi=110)
        print(path)


if __name__ == "__main__":
    main()
