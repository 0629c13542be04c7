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


def force_depth_figure(depth, curves: dict, path: str | Path, errors=None, title: str = "") -> Path:
    """Force against depth: ``curves`` maps a label to forces (mN) at ``depth`` (mm); the first
    is drawn as measured points (with ``errors`` as error bars), the rest as lines."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(5.6, 4.2), constrained_layout=True)
    for k, (label, f) in enumerate(curves.items()):
        if k == 0:
            ax.errorbar(depth, f, yerr=errors, fmt="o", ms=4, color="k", label=label)
        else:
            ax.plot(depth, f, "-", lw=1.8, label=label)
    ax.set_xlabel("indentation depth (mm)")
    ax.set_ylabel("indenter force, whole specimen (mN)")
    ax.set_title(title or "force against depth")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


def displacement_maps_figure(top_xyz: np.ndarray, u: np.ndarray, path: str | Path, title: str = "") -> Path:
    """Top-surface displacement maps (ux, uy, uz) of one step over the full field (the quarter
    model mirrored by its symmetry planes), with the fiber direction (+y) marked."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    x, y = top_xyz[:, 0], top_xyz[:, 1]
    X = np.concatenate([x, -x, x, -x])
    Y = np.concatenate([y, y, -y, -y])
    sx = np.concatenate([np.ones_like(x), -np.ones_like(x), np.ones_like(x), -np.ones_like(x)])
    sy = np.concatenate([np.ones_like(y), np.ones_like(y), -np.ones_like(y), -np.ones_like(y)])
    U = np.tile(u, (4, 1))
    U[:, 0] *= sx
    U[:, 1] *= sy
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2), constrained_layout=True)
    lim = min(float(np.abs(x).max()), 25.0)
    for j, ax in enumerate(axes):
        v = np.abs(U[:, j]).max() or 1.0
        cs = ax.tricontourf(
            X,
            Y,
            U[:, j],
            levels=21,
            cmap="RdBu_r" if j < 2 else "viridis",
            vmin=-v if j < 2 else None,
            vmax=v if j < 2 else None,
        )
        fig.colorbar(cs, ax=ax, label=f"u{'xyz'[j]} (mm)")
        ax.annotate(
            "",
            xy=(0, 0.8 * lim),
            xytext=(0, 0.45 * lim),
            arrowprops={"arrowstyle": "->", "lw": 2, "color": "k"},
        )
        ax.text(0.03 * lim, 0.62 * lim, "fibers", fontsize=9)
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
        ax.set_aspect("equal")
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
    fig.suptitle(title or "top-surface displacement")
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def parity_figure(pairs: dict, path: str | Path, title: str = "") -> Path:
    """Surrogate against FE (held-out points): one panel per entry of ``pairs`` = {label: (fe, surrogate)}."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(
        1, len(pairs), figsize=(4.4 * len(pairs), 4.2), constrained_layout=True, squeeze=False
    )
    for ax, (label, (fe, sur)) in zip(axes[0], pairs.items(), strict=True):
        fe, sur = np.ravel(fe), np.ravel(sur)
        ax.plot(fe, sur, ".", ms=2, alpha=0.4)
        lo, hi = float(min(fe.min(), sur.min())), float(max(fe.max(), sur.max()))
        ax.plot([lo, hi], [lo, hi], "k-", lw=0.8)
        ax.set_xlabel(f"FE {label}")
        ax.set_ylabel(f"surrogate {label}")
        ax.grid(alpha=0.3)
    fig.suptitle(title or "surrogate against FE on held-out points")
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def mesh_figure(nodes: np.ndarray, elements: np.ndarray, path: str | Path, title: str = "") -> Path:
    """The block mesh: the edges of the element faces on the top and the two symmetry planes, in 3D."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    edges = np.concatenate(
        [
            elements[:, [a, b]]
            for a, b in (
                (0, 1),
                (1, 2),
                (2, 3),
                (3, 0),
                (4, 5),
                (5, 6),
                (6, 7),
                (7, 4),
                (0, 4),
                (1, 5),
                (2, 6),
                (3, 7),
            )
        ]
    )
    edges = np.unique(np.sort(edges, axis=1), axis=0)
    p0, p1 = nodes[edges[:, 0]], nodes[edges[:, 1]]
    top, z_max = nodes[:, 2].max(), nodes[:, 2].max()
    on_face = (
        ((p0[:, 2] == top) & (p1[:, 2] == top))
        | ((p0[:, 0] == 0) & (p1[:, 0] == 0))
        | ((p0[:, 1] == 0) & (p1[:, 1] == 0))
    )
    fig = plt.figure(figsize=(6, 5.4), constrained_layout=True)
    ax = fig.add_subplot(projection="3d")
    for a, b in zip(p0[on_face], p1[on_face], strict=True):
        ax.plot(*np.stack([a, b]).T, color="k", lw=0.3)
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
    ax.set_box_aspect(np.ptp(nodes, axis=0))
    ax.view_init(elev=25, azim=225)
    ax.set_title(
        title or f"quarter block: {len(nodes)} nodes, {len(elements)} hex8 (indentation at (0, 0, {z_max:g}))"
    )
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
