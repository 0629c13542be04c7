"""Figures of the studio (matplotlib, Agg): the objective map with its certainty ellipse (paper
Fig. 8) and the comparison of candidate test designs. Each function writes one PNG and returns
its path; the numerics come from the packages."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.colors import LogNorm
from matplotlib.ticker import ScalarFormatter


def certainty_ellipse(H: np.ndarray, s: float, centre=(1.0, 1.0), n: int = 200) -> np.ndarray:
    """Points (n, 2) of the level set (theta_bar - centre)^T H (theta_bar - centre) = s^2
    (the ellipse of Fig. 8, authors-code-notes.md); H in theta_bar, positive definite."""
    w, V = np.linalg.eigh(np.asarray(H, float))
    if np.any(w <= 0):
        raise ValueError("the Hessian is not positive definite: the certainty region is unbounded")
    t = np.linspace(0.0, 2.0 * np.pi, n)
    circle = np.stack([np.cos(t), np.sin(t)])
    return (V @ (circle * (s / np.sqrt(w))[:, None])).T + np.asarray(centre)


def objective_map_figure(
    c1_bar: np.ndarray,
    c5_bar: np.ndarray,
    F: np.ndarray,
    H: np.ndarray,
    s: float,
    path: str | Path,
    title: str = "",
) -> Path:
    """Fig. 8: F over the normalised (c1, c5) plane from scattered or gridded points, the
    certainty ellipse from H at theta* = (1, 1), and theta*."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(6.4, 5.2), constrained_layout=True)
    F = np.maximum(np.asarray(F, float), 1e-12)
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
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


def design_comparison_figure(table: pd.DataFrame, path: str | Path) -> Path:
    """Bounds of c1 and c5 (optimised weights) against the maximum depth, one line per indenter
    radius and field of view: which test identifies c5 best."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2), constrained_layout=True)
    groups = table.fillna({"fov_mm": np.inf}).groupby(["radius_mm", "fov_mm", "every", "s"], sort=True)
    for (radius, fov, every, s), g in groups:
        g = g.sort_values("max_depth_mm")
        label = f"R = {radius:g} mm" + ("" if np.isinf(fov) else f", FOV {fov:g} mm")
        label += "" if every == 1 else f", every {every} steps"
        label += f", s = {s:g}" if table["s"].nunique() > 1 else ""
        for ax, col in zip(axes, ("c1_pct_optimised", "c5_pct_optimised"), strict=True):
            ax.plot(g["max_depth_mm"], g[col], "o-", label=label)
    for ax, name in zip(axes, ("c1", "c5"), strict=True):
        ax.set_xlabel("maximum indentation depth (mm)")
        ax.set_ylabel(f"certainty bound of {name} (+- %)")
        ax.set_yscale("log")
        ax.yaxis.set_major_formatter(ScalarFormatter())
        ax.yaxis.set_minor_formatter(ScalarFormatter())
        ax.grid(True, which="both", alpha=0.3)
    axes[1].legend(fontsize=8)
    fig.suptitle("candidate test designs (weights optimised per design, eq. 6)")
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


def corner_figure(
    posterior, path: str | Path, fit_theta=None, fit_hessian=None, s: float | None = None
) -> Path:
    """Corner plot (corner package) of posterior samples, with the fit and its eq. 6 certainty
    ellipse (H in theta_bar = theta / theta_hat) overlaid."""
    import corner

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    labels = [f"{name} (kPa)" for name in posterior.parameters]
    fig = corner.corner(
        posterior.samples,
        labels=labels,
        quantiles=[0.025, 0.5, 0.975],
        show_titles=True,
        title_fmt=".4g",
        truths=None if fit_theta is None else list(fit_theta),
        truth_color="tab:red",
    )
    if fit_theta is not None and fit_hessian is not None and s is not None:
        e = certainty_ellipse(fit_hessian, s) * np.asarray(fit_theta)  # back to kPa
        ax = fig.axes[len(labels)]  # lower-left panel: c5 against c1
        ax.plot(e[:, 0], e[:, 1], color="tab:red", lw=1.5, label="Hessian ellipse (eq. 6)")
        ax.legend(fontsize=7, loc="upper right")
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
