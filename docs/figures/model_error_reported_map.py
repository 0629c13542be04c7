"""c5's 95 % half-width as a plain fit *reports* it over the paper's box at both radii (every part:
statistical, discrepancy, budget, the surrogate's own, processing), beside what it would be with
the surrogate's part taken over its held-out points with mu >= 0.3 only (what more low-level
points at small mu could give at most: issue 57's option (iii)) and over the 52 held-out points
nearest the fit (the local part of option (i)).

    .venv/bin/python benchmarks/probes/reported_width_map.py docs/validation/data/reported-width-map.json
    .venv/bin/python docs/figures/model_error_reported_map.py

Reads the probe's file; writes docs/validation/figures/model-error-reported-map-c5.png.
"""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from indentation_studio.studio.figures import save_figure

DOCS = Path(__file__).resolve().parents[1]
DATA = DOCS / "validation" / "data" / "reported-width-map.json"
OUT = DOCS / "validation" / "figures" / "model-error-reported-map-c5.png"
COLUMNS = (
    ("reported", lambda r: r["half_width_pct"][1]),
    ("(iii): surrogate's part over mu >= 0.3", lambda r: r["c5_pct_with_mid_mu_surrogate_part"]),
    ("(i): surrogate's part near the fit", lambda r: r["c5_pct_with_local_surrogate_part"]),
)


def reported_map_figure(rows: list[dict]) -> Figure:
    """One panel per radius and column: c5's half-width at each grid point (the white line 6 %).

    Parameters
    ----------
    rows : list of dict
        The probe's rows (``radius``, ``truth``, ``half_width_pct``,
        ``c5_pct_with_mid_mu_surrogate_part``).

    Returns
    -------
    matplotlib.figure.Figure
    """
    radii = sorted({r["radius"] for r in rows})
    fig, axes = plt.subplots(len(radii), len(COLUMNS), figsize=(13.5, 3.6 * len(radii)), squeeze=False)
    for i, radius in enumerate(radii):
        here = [r for r in rows if r["radius"] == radius]
        c1 = np.unique(np.round([r["truth"][0] for r in here], 6))
        c5 = np.unique(np.round([r["truth"][1] for r in here], 6))
        for j, (label, value) in enumerate(COLUMNS):
            grid = np.full((len(c5), len(c1)), np.nan)
            for r in here:
                a = np.searchsorted(c1, round(r["truth"][0], 6))
                b = np.searchsorted(c5, round(r["truth"][1], 6))
                grid[b, a] = value(r)
            ax = axes[i, j]
            image = ax.imshow(grid, origin="lower", cmap="viridis", vmin=0, vmax=15, aspect="auto")
            if np.nanmin(grid) < 6 < np.nanmax(grid):
                ax.contour(grid, levels=[6.0], colors="white", linewidths=1.5)
            for b in range(len(c5)):
                for a in range(len(c1)):
                    ax.text(a, b, f"{grid[b, a]:.1f}", ha="center", va="center", color="white", fontsize=8)
            ax.set_xticks(range(len(c1)), [f"{v:.3g}" for v in c1])
            ax.set_yticks(range(len(c5)), [f"{v:.3g}" for v in c5])
            ax.set(xlabel="c1, kPa (log-spaced)", ylabel="c5, kPa (log-spaced)")
            ax.set_title(f"R = {radius:g} mm: {label}", fontsize=10)
            fig.colorbar(image, ax=ax, label="c5's 95 % half-width, %")
    fig.suptitle("c5's 95 % half-width a plain fit reports (lab-like data made on the shipped surrogate)")
    fig.tight_layout()
    return fig


def main() -> None:
    rows = json.loads(DATA.read_text())["rows"]
    save_figure(reported_map_figure(rows), OUT, 120)
    for radius in sorted({r["radius"] for r in rows}):
        here = [r for r in rows if r["radius"] == radius]
        for label, value in COLUMNS:
            v = np.array([value(r) for r in here])
            print(
                f"R = {radius:g} mm, {label}: {v.min():.2f} to {v.max():.2f} %, above 6 % at {(v > 6).sum()} of {len(v)}"
            )


if __name__ == "__main__":
    main()
