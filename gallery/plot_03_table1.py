"""
Table 1
=======

The certainty bounds (eq. 6, s = 0.05) of c1 and c5 at theta* = (10, 350) kPa for each row of the
paper's Table 1 (force alone, the field alone, both), from the exact Gauss-Newton Hessians of the
coarse mesh, beside the paper's bounds (:doc:`../guide/design`).
"""

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.ticker import NullFormatter

import indentation_studio as ins

spec = ins.ModelSpec(mesh=ins.MeshChoice("coarse"), protocol=ins.Protocol(steps=4))
study = ins.fe_design_study(spec, (10.0, 350.0), method="exact")
rows = ins.compare_with_paper(study.term_hessians, 0.05)
for row in rows:
    print(
        f"{row.name:>24}: c1 {row.c1_pct_at_paper_weights:6.2f} % (paper {row.paper_c1_pct:5.2f}), "
        f"c5 {row.c5_pct_at_paper_weights:6.2f} % (paper {row.paper_c5_pct:5.2f})"
    )

# %%
# The bounds at the paper's weights, ours (coarse mesh, 4 steps) and the paper's, on a log scale.
fig, axes = plt.subplots(1, 2, figsize=(10, 4.2), constrained_layout=True, sharey=True)
y = np.arange(len(rows))
for ax, (label, ours, paper) in zip(
    axes,
    (
        ("c1", [r.c1_pct_at_paper_weights for r in rows], [r.paper_c1_pct for r in rows]),
        ("c5", [r.c5_pct_at_paper_weights for r in rows], [r.paper_c5_pct for r in rows]),
    ),
    strict=True,
):
    ax.barh(y - 0.2, ours, height=0.4, label="this model (coarse)")
    ax.barh(y + 0.2, paper, height=0.4, label="paper")
    ax.set_xscale("log")
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel(f"{label} bound (+- %)")
axes[0].set_yticks(y, [r.name for r in rows])
axes[0].invert_yaxis()
legend = axes[1].legend(loc="lower right")
