"""The default (mu marginalised) against the stick assumed: the c5 bias of each synthetic
experiment's fit, drawn from the table of docs/validation/friction.md, "The default: mu
marginalised" (no run).

    .venv/bin/python docs/figures/friction.py

Writes docs/validation/figures/friction-default.png.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from _page_table import FIGURES, page_table

from indentation_studio.studio.figures import save_figure


def c5_bias(cell: str) -> float:
    return float(cell.split("/")[1].strip().rstrip("%").strip())


def figure():
    rows = page_table("friction", "truth | mu of the data | stick assumed")
    labels = [f"{r['truth']} kPa\nmu {r['mu of the data']}" for r in rows]
    x = np.arange(len(rows))
    fig, ax = plt.subplots(figsize=(8, 3.8), layout="constrained")
    ax.bar(x - 0.2, [c5_bias(r["stick assumed: c1 / c5 bias"]) for r in rows], 0.4, label="stick assumed")
    ax.bar(
        x + 0.2,
        [c5_bias(r["mu marginalised (default): c1 / c5 bias"]) for r in rows],
        0.4,
        label="mu marginalised (the default)",
    )
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xticks(x, labels, fontsize=7)
    ax.set_ylabel("c5 bias of the fit (%)")
    ax.set_title("Synthetic experiments on default, fitted with the stick surrogate s9")
    ax.legend(fontsize=8)
    return fig


if __name__ == "__main__":
    print(save_figure(figure(), FIGURES / "friction-default.png"))
