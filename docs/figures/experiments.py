"""The shipped example's force record (``examples/synthetic-12-250/force.csv``): the force at every
reading of the 28 holds against the step's depth, as the data check reads it (no run).

    .venv/bin/python docs/figures/experiments.py

Writes docs/validation/figures/experiments-example-force.png.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import pandas as pd
from _page_table import FIGURES

from indentation_studio.studio.figures import force_depth_figure, save_figure

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "synthetic-12-250"


def figure():
    force = pd.read_csv(EXAMPLE / "force.csv")
    holds = force.groupby("step")["force_mN"]
    depth = 0.5 * holds.first().index.to_numpy()
    curves = {
        "start of each hold": holds.first().to_numpy(),
        "end of each hold (relaxed)": holds.last().to_numpy(),
    }
    return force_depth_figure(depth, curves, title="examples/synthetic-12-250: the force record, 28 holds")


if __name__ == "__main__":
    print(save_figure(figure(), FIGURES / "experiments-example-force.png"))
