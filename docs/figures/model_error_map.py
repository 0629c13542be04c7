"""c5's (and c1's) 95 % half-width over the paper's box at both radii, from the shipped budgets of
the high-fidelity level a fit's surrogate emulates (contact-L3): the budget's width (level 3's fit
corrected to level 4, run at the nine points of both radii) combined with a
typical experiment's statistical half-width (2 % force, 0.02 mm DIC noise) at the nine points, both
interpolated between the points as a fit reads them and held at the nearest points' largest outside
them (hatched). The white line is 6 %.

    .venv/bin/python docs/figures/model_error_map.py

Writes docs/validation/figures/model-error-map-c5.png and model-error-map-c1.png and prints, per
radius, the share of the box (in log c1, log c5) where c5's half-width exceeds 6 %.
"""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import numpy as np

from indentation_studio.studio.figures import budget_map_figure, save_figure
from indentation_studio.surrogate.error_budgets import budget_map, remaining_bias, shipped_budgets_folder

OUT = Path(__file__).resolve().parents[1] / "validation" / "figures"
MODEL = "contact-L3"


def maps() -> dict:
    """The budget maps at both radii over the paper's box."""
    c1, c5 = np.geomspace(1.0, 21.0, 41), np.geomspace(82.5, 578.0, 41)
    out = {}
    for radius in (4.77, 8.0):
        path = shipped_budgets_folder() / f"fit-model-R{radius:g}.json"
        rows = [r for r in json.loads(path.read_text())["rows"] if r["model"] == MODEL]
        noise = {p: [r[f"{p}_half_width_pct"] for r in rows] for p in ("c1", "c5")}
        out[f"R = {radius:g} mm"] = budget_map(remaining_bias(path, MODEL), c1, c5, noise_pct=noise)
    return out


def main() -> None:
    found = maps()
    for p in ("c5", "c1"):
        fig = budget_map_figure(
            found,
            key=f"total_{p}_pct",
            title=f"{p}: 95 % half-width of a fit on {MODEL} (budget and typical noise) over the paper's box",
        )
        save_figure(fig, OUT / f"model-error-map-{p}.png", 120)
    for name, m in found.items():
        above = m["total_c5_pct"] > 6.0
        print(
            f"{name}: c5 half-width {np.nanmin(m['total_c5_pct']):.2f} to {np.nanmax(m['total_c5_pct']):.2f} %, "
            f"above 6 % on {100 * above.mean():.0f} % of the box; verified (inside the points) "
            f"{100 * m['verified'].mean():.0f} %; c1 {np.nanmin(m['total_c1_pct']):.2f} to "
            f"{np.nanmax(m['total_c1_pct']):.2f} %"
        )


if __name__ == "__main__":
    main()
