"""The design's figures: F over the normalised (c1, c5) plane with eq. 6's certainty ellipse
(paper Fig. 8), and the bounds of each candidate test against its depth."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.colors import LogNorm
from matplotlib.figure import Figure
from matplotlib.ticker import ScalarFormatter

from ...design.objective_over_plane import ObjectiveMap


def certainty_ellipse(H: np.ndarray, s: float, centre=(1.0, 1.0), n: int = 200) -> np.ndarray:
    """Points (n, 2) of the level set (theta_bar - centre)^T H (theta_bar - centre) = s^2
    (the ellipse of Fig. 8); H in theta_bar, positive definite."""
    w, V = np.linalg.eigh(np.asarray(H, float))
    if np.any(w <= 0):
        raise ValueError("the Hessian is not positive definite: the certainty region is unbounded")
    t = np.linspace(0.0, 2.0 * np.pi, n)
    circle = np.stack([np.cos(t), np.sin(t)])
    return (V @ (circle * (s / np.sqrt(w))[:, None])).T + np.asarray(centre)


def objective_map_figure(omap: ObjectiveMap, title: str = "") -> Figure:
    """Paper Fig. 8: F over the normalised (c1, c5) plane, the certainty ellipse from H, and theta*.

    Parameters
    ----------
    omap : ObjectiveMap
        F at scattered or gridded points, H at theta* = (1, 1) and its bounds
        (:func:`design.objective_over_plane.objective_map`).
    title : str, default ""
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The contour plot.
    """
    c1_bar, c5_bar = omap.theta_bar[:, 0], omap.theta_bar[:, 1]
    H, s = omap.hessian, omap.s
    fig, ax = plt.subplots(figsize=(6.4, 5.2), constrained_layout=True)
    F = np.maximum(np.asarray(omap.F, float), 1e-12)
    levels = np.geomspace(max(F.min(), 1e-8), F.max(), 30)
    cs = ax.tricontourf(
        np.ravel(c1_bar), np.ravel(c5_bar), np.ravel(F), levels=levels, norm=LogNorm(), cmap="viridis"
    )
    fig.colorbar(cs, ax=ax, label="objective F (eq. 5)", format="%.0e")
    ax.plot(np.ravel(c1_bar), np.ravel(c5_bar), ".", ms=1.5, color="k", alpha=0.3, label="simulations")
    e = certainty_ellipse(H, s)
    ax.plot(e[:, 0], e[:, 1], color="white", lw=2, label=f"certainty ellipse (s = {s:g})")
    ax.plot([1.0], [1.0], "o", color="white", mec="k", ms=7, label=r"$\theta^*$")
    ax.set_xlabel(r"$\bar c_1 = c_1 / c_1^*$")
    ax.set_ylabel(r"$\bar c_5 = c_5 / c_5^*$")
    ax.set_title(title or "objective over the normalised parameter plane")
    ax.legend(loc="upper right", fontsize=8, framealpha=0.7)
    return fig


def design_comparison_figure(table: pd.DataFrame) -> Figure:
    """Bounds of c1 and c5 (optimised weights) against the maximum depth: which test identifies c5 best.

    The statistical bound (eq. 6) as a line per indenter radius and field of view; where a budget
    exists for the test, the bound with the model error as open squares beside it.

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`design.experiment_choice.compare_designs`' table; one line per indenter radius and
        field of view.

    Returns
    -------
    matplotlib.figure.Figure
        The plot.
    """
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2), constrained_layout=True)
    groups = table.fillna({"fov_mm": np.inf}).groupby(["radius_mm", "fov_mm", "every", "s"], sort=True)
    for (radius, fov, every, s), g in groups:
        g = g.sort_values("max_depth_mm")
        label = f"R = {radius:g} mm" + ("" if np.isinf(fov) else f", FOV {fov:g} mm")
        label += "" if every == 1 else f", every {every} steps"
        label += f", s = {s:g}" if table["s"].nunique() > 1 else ""
        for ax, name in zip(axes, ("c1", "c5"), strict=True):
            (line,) = ax.plot(
                g["max_depth_mm"], g[f"{name}_pct_optimised"], "o-", label=f"{label}: statistical"
            )
            if f"{name}_model_pct" in g and g[f"{name}_model_pct"].notna().any():
                known = g[g[f"{name}_model_pct"].notna()]
                ax.plot(
                    known["max_depth_mm"],
                    known[f"{name}_total_pct"],
                    "s--",
                    color=line.get_color(),
                    mfc="none",
                    ms=8,
                    label=f"{label}: with model error",
                )
    for ax, name in zip(axes, ("c1", "c5"), strict=True):
        ax.set_xlabel("maximum indentation depth (mm)")
        ax.set_ylabel(f"certainty bound of {name} (+- %)")
        ax.set_yscale("log")
        ax.yaxis.set_major_formatter(ScalarFormatter())
        ax.yaxis.set_minor_formatter(ScalarFormatter())
        ax.grid(True, which="both", alpha=0.3)
    axes[1].legend(fontsize=8)
    fig.suptitle(
        "candidate test designs (weights optimised per design, eq. 6); open squares: with the model error "
        "where a budget exists for that test",
        fontsize=9,
    )
    return fig
