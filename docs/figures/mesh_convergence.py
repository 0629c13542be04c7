"""The presets' and candidate gradings' convergence against ``reference`` (eq. 1a, 1b), drawn from
the table of docs/validation/mesh-convergence.md (no run).

    .venv/bin/python docs/figures/mesh_convergence.py

Writes docs/validation/figures/mesh-convergence.png.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from _page_table import FIGURES, number, page_table

from indentation_studio.studio.figures import save_figure


def figure():
    rows = page_table("mesh-convergence", "mesh (h0-core-graded)")
    nodes = [number(r["nodes"]) for r in rows]
    fig, ax = plt.subplots(figsize=(7, 4), layout="constrained")
    for key, label, marker in [
        ("E_u eq. 1b, whole top", "E_u, whole top surface (eq. 1b)", "o"),
        ("||dF|| / ||F||", "||dF|| / ||F|| (eq. 1a without 1/N_s)", "s"),
        ("E_u eq. 1b, nodes in contact", "E_u, nodes in contact", "^"),
    ]:
        ax.plot(nodes, [number(r[key]) for r in rows], marker, label=label)
    for r, n in zip(rows, nodes, strict=True):
        if r["mesh (h0-core-graded)"].startswith("`"):
            ax.annotate(
                r["mesh (h0-core-graded)"].split()[0].strip("`"),
                (n, number(r["E_u eq. 1b, whole top"])),
                textcoords="offset points",
                xytext=(4, 4),
            )
    ax.axhline(1.0, color="k", lw=0.8, ls=":", label="the paper's 1 %")
    ax.set_xscale("log")
    ax.set_xlabel("nodes (quarter model)")
    ax.set_ylabel("error against reference (%)")
    ax.set_title("c1 = 10, c5 = 350 kPa, R = 4.77 mm, 28 x 0.5 mm")
    ax.legend(fontsize=8)
    return fig


if __name__ == "__main__":
    print(save_figure(figure(), FIGURES / "mesh-convergence.png"))
