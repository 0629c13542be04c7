"""The composite phantom at R = 8 mm as an experiment: c1 and c5 of the homogeneous model's fits
(stick assumed, mu marginalised), the paper's Table 2 row and the equibiaxial fit, drawn from the
table of docs/validation/composite.md, "The composite indentation, as an experiment" (no run).

    .venv/bin/python docs/figures/composite.py

Writes docs/validation/figures/composite-fits.png.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from _page_table import FIGURES, number, page_table

from indentation_studio.studio.figures import save_figure


def figure():
    rows = page_table("composite", "R = 8 mm, paper-size mesh")
    names = [r["R = 8 mm, paper-size mesh (93,248 nodes)"].split(" (")[0] for r in rows]
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.6), layout="constrained")
    for ax, key in zip(axes, ("c1 (kPa)", "c5 (kPa)"), strict=True):
        ax.barh(names, [number(r[key]) for r in rows], color=["C0", "C1", "C2", "C3"][: len(rows)])
        ax.set_xlabel(key)
        ax.invert_yaxis()
    axes[1].set_yticks([])
    fig.suptitle("The composite phantom indented (R = 8 mm), fitted with the homogeneous model")
    return fig


if __name__ == "__main__":
    print(save_figure(figure(), FIGURES / "composite-fits.png"))
