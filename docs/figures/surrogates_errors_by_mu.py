"""Benchmark (by hand): the shipped surrogates' held-out errors by mu, as a figure and a table.

Each shipped surrogate keeps the held-out errors of its low level (the stick GP plus the slip MLP
over (c1, c5, mu) on contact-L1: each of the mu campaign's 512 points predicted by the model of the
5-fold cross-validation that did not see it; ``surrogate.emulation_error``). They are pooled within
bands of mu even in log over the prior (0.1 to 3): the force's RMS error (percent, per step) and the
field's (mm, every top node and step), beside the stick's (its 32 held-out test points, from the
manifest). What a fit feels of them is on the same page (``benchmarks/probes/surrogate_fit_shift.py``).

    .venv/bin/python docs/figures/surrogates_errors_by_mu.py \\
        --out docs/validation/figures/surrogate-errors-by-mu.png \\
        --json docs/validation/data/surrogate-errors-by-mu.json
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from indentation_studio.atomic_write import atomic_write_json
from indentation_studio.surrogate.shipped import load_shipped, shipped_surrogates

#: Bands of mu, even in log over the studio's prior.
EDGES = np.geomspace(0.1, 3.0 + 1e-9, 7)


def bands(entry) -> dict:
    """The shipped surrogate's held-out errors by band of mu, and its stick's."""
    model = load_shipped(entry)
    errors = getattr(model, "low_emulation_error", None) or model.emulation_error
    rows = errors.describe_bands(list(model.parameters).index("mu"), EDGES)
    stick = entry.provenance.get("held_out", {}).get("stick") or {}
    return {
        "surrogate": entry.name,
        "radius_mm": entry.radius,
        "source": errors.source,
        "bands": rows,
        "stick": {k: stick.get(k) for k in ("points", "source", "force_rms_pct", "field_rms_mm")},
    }


def figure(tables: list[dict]):
    """Force and field RMS against mu, one line per radius, the stick at the right."""
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), constrained_layout=True)
    stick_x = 5.0
    for table, colour in zip(tables, ("tab:blue", "tab:orange"), strict=False):
        mid = [np.sqrt(b["low"] * b["high"]) for b in table["bands"]]
        label = f"R = {table['radius_mm']:g} mm"
        for ax, key in zip(axes, ("force_rms_pct", "field_rms_mm"), strict=True):
            ax.plot(mid, [b[key] for b in table["bands"]], "o-", color=colour, label=label)
            if table["stick"].get(key) is not None:
                ax.plot([stick_x], [table["stick"][key]], "s", color=colour)
    for ax, title in zip(
        axes, ("force, RMS % per step", "field, RMS mm (every top node and step)"), strict=True
    ):
        ax.set_xscale("log")
        ax.minorticks_off()
        ax.set_xticks([0.1, 0.3, 1, 3, stick_x], ["0.1", "0.3", "1", "3", "stick"])
        ax.set_xlabel("friction coefficient mu (band centre)")
        ax.set_title(title, fontsize=10)
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(
        "Shipped surrogates: held-out errors by mu (5-fold over 512 points; stick: 32 test points)",
        fontsize=10,
    )
    return fig


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, required=True, help="the figure (PNG)")
    ap.add_argument("--json", type=Path, help="the numbers")
    args = ap.parse_args()
    tables = [bands(entry) for entry in sorted(shipped_surrogates(), key=lambda e: e.radius)]
    print("| R (mm) | mu band | points | force RMS % | field RMS mm |")
    print("|---|---|---|---|---|")
    for t in tables:
        for b in t["bands"]:
            print(
                f"| {t['radius_mm']:g} | {b['low']:.3g} to {b['high']:.3g} | {b['points']} | "
                f"{b['force_rms_pct']:.3f} | {b['field_rms_mm']:.4f} |"
            )
        s = t["stick"]
        print(
            f"| {t['radius_mm']:g} | stick | {s['points']} | {s['force_rms_pct']:.3f} | {s['field_rms_mm']:.4f} |"
        )
    args.out.parent.mkdir(parents=True, exist_ok=True)
    figure(tables).savefig(args.out, dpi=110)
    if args.json:
        atomic_write_json(args.json, {"tables": tables, "command": " ".join(["python", *sys.argv])})
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
