"""The validation's figures: the composite's equibiaxial fit and its agreement with FE, a
verification study's quantities over the mesh levels, and the model-error budget's maps."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from ...forward.material import equibiaxial_stress_incompressible


def equibiaxial_figure(
    stretch: np.ndarray,
    sigma_fiber: np.ndarray,
    sigma_transverse: np.ndarray,
    fit: dict[str, float] | None = None,
    title: str = "",
) -> Figure:
    """Paper Fig. 14: true (Cauchy) stress against stretch under equibiaxial stretch, with eq. 10 fitted.

    Parameters
    ----------
    stretch : numpy.ndarray
        The stretches.
    sigma_fiber, sigma_transverse : numpy.ndarray
        Cauchy stress along and across the fibers, kPa (points: the composite FE model).
    fit : dict of str to float, optional
        ``{"c1": ..., "c5": ...}`` (kPa): eq. 10a, 10b drawn as lines.
    title : str, default ""
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The plot.
    """
    lam = np.asarray(stretch, dtype=float)
    fig, ax = plt.subplots(figsize=(5.6, 4.2), constrained_layout=True)
    ax.plot(lam, sigma_fiber, "o", ms=4, color="C0", label="FE, along the fibers")
    ax.plot(lam, sigma_transverse, "s", ms=4, color="C1", label="FE, across the fibers")
    if fit is not None:
        grid = np.linspace(1.0, float(lam.max()), 200)
        s11, s22 = equibiaxial_stress_incompressible(grid, fit["c1"], fit["c5"])
        text = f"eq. 10, c1 = {fit['c1']:.2f}, c5 = {fit['c5']:.0f} kPa"
        ax.plot(grid, s11, "-", color="C0", label=f"{text} (10a)")
        ax.plot(grid, s22, "--", color="C1", label="(10b)")
    ax.set_xlabel("stretch lambda")
    ax.set_ylabel("true stress (kPa)")
    ax.set_title(title or "equibiaxial stretch of the composite")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def composite_comparison_figure(comparison, within_mm: float = 20.0, title: str = "") -> Figure:
    """Paper Fig. 12, 13 for the composite phantom: (a) force against depth, the composite (points)
    and the homogeneous model at the fitted (c1, c5) (line); (b, c) the composite's top-surface
    uz and in-plane |u| at the last step over the full field (quarter mirrored); (d) uz of the
    composite minus the homogeneous model's. The top layer's fibers (along y) are drawn as
    dashed bands: they imprint the surface. ``comparison`` is an
    :class:`inference.experiment.composite_comparison.CompositeComparison`."""
    c = comparison
    xy = c.top_xyz[:, :2]
    keep = np.all(np.abs(xy) <= within_mm, axis=1)
    x, y = xy[keep, 0], xy[keep, 1]
    X = np.concatenate([x, -x, x, -x])
    Y = np.concatenate([y, y, -y, -y])
    uc = c.field_composite[-1][keep]
    du = c.field_difference[-1][keep]
    maps = [
        ("composite uz (mm)", np.tile(uc[:, 2], 4), "viridis", None),
        ("composite in-plane |u| (mm)", np.tile(np.hypot(uc[:, 0], uc[:, 1]), 4), "magma", None),
        ("uz, composite - homogeneous (mm)", np.tile(du[:, 2], 4), "RdBu_r", "sym"),
    ]
    fig, axes = plt.subplots(1, 4, figsize=(18, 4.3), constrained_layout=True)
    ax = axes[0]
    ax.plot(c.depth, c.force_composite, "o", ms=4, color="C0", label="composite FE")
    t1, t5 = c.theta
    ax.plot(
        c.depth, c.force_homogeneous, "-", lw=1.8, color="C3", label=f"homogeneous {{{t1:.2f}, {t5:.0f}}} kPa"
    )
    ax.set_xlabel("indentation depth (mm)")
    ax.set_ylabel("indenter force, whole specimen (mN)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    for ax, (label, v, cmap, sym) in zip(axes[1:], maps, strict=True):
        lim = float(np.nanmax(np.abs(v))) or 1.0
        cs = ax.tricontourf(
            X, Y, v, levels=21, cmap=cmap, vmin=-lim if sym else None, vmax=lim if sym else None
        )
        fig.colorbar(cs, ax=ax, label=label)
        for lo, hi in c.fiber_bands:
            if lo > within_mm:
                continue
            for a, b in ((lo, hi), (-hi, -lo)):
                ax.axvline(a, color="w" if cmap != "RdBu_r" else "k", ls="--", lw=0.6, alpha=0.7)
                ax.axvline(b, color="w" if cmap != "RdBu_r" else "k", ls="--", lw=0.6, alpha=0.7)
        ax.set_xlim(-within_mm, within_mm)
        ax.set_ylim(-within_mm, within_mm)
        ax.set_aspect("equal")
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm), fiber direction")
    fig.suptitle(title or f"composite phantom at {c.depth[-1]:g} mm: top fibers dashed")
    return fig


def verification_figure(case: dict, names: tuple[str, ...] | None = None, title: str = "") -> Figure:
    """A verification study's convergence: |f_k - f_ext| / |f_ext| against the cell size h, log-log.

    One panel per quantity, with the line of the finest triplet's observed order p through the
    finest level.

    Parameters
    ----------
    case : dict
        One case of :func:`inference.budgets.verification_study.run_verification_study` (its
        ``quantities``).
    names : tuple of str, optional
        The quantities to draw; default all.
    title : str, default ""
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The panels.
    """
    quantities = case["quantities"]
    names = tuple(names or quantities)
    cols = min(3, len(names))
    rows = -(-len(names) // cols)
    fig, axes = plt.subplots(
        rows, cols, figsize=(3.6 * cols, 3.0 * rows), constrained_layout=True, squeeze=False
    )
    for ax, name in zip(axes.ravel(), names, strict=False):
        q = quantities[name]
        h = np.asarray(q["sizes"], float)
        f = np.asarray(q["values"], float)
        ext, p = q["extrapolated"], q["orders"][0]
        err = np.abs(f - ext) / max(abs(ext), 1e-300)
        shown = err > 0
        ax.loglog(h[shown], err[shown], "o-", color="C0", label="levels")
        if p is not None and np.isfinite(p) and err[0] > 0:
            hh = np.array([h.min(), h.max()])
            ax.loglog(hh, err[0] * (hh / h[0]) ** p, "--", color="C1", label=f"p = {p:.2f}")
        state = "asymptotic" if q["asymptotic"] else "not asymptotic"
        ax.set_title(f"{name}\n{state}", fontsize=9)
        ax.set_xlabel("h (mm)")
        ax.set_ylabel("|f - f_ext| / |f_ext|")
        ax.legend(fontsize=7)
    for ax in axes.ravel()[len(names) :]:
        ax.set_visible(False)
    if title:
        fig.suptitle(title)
    return fig


def budget_map_figure(
    maps: dict, *, target_pct: float = 6.0, key: str = "total_c5_pct", title: str = ""
) -> Figure:
    """Maps of a parameter's 95 % half-width over (c1, c5), one panel per test, with the budget's points.

    Parameters
    ----------
    maps : dict
        A panel's title (e.g. ``"R = 8 mm"``) to a :func:`surrogate.error_budgets.budget_map`.
    target_pct : float, default 6.0
        The contour drawn: where a test cannot reach it.
    key : str, default "total_c5_pct"
        The map shown (``c5_pct``: the budget's part alone).
    title : str, default ""
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The maps.
    """
    fig, axes = plt.subplots(
        1, len(maps), figsize=(5.2 * len(maps), 4.4), squeeze=False, constrained_layout=True
    )
    top = max(float(np.nanmax(m[key])) for m in maps.values())
    levels = np.linspace(0.0, max(top, target_pct * 1.2), 13)
    for ax, (name, m) in zip(axes[0], maps.items(), strict=True):
        X, Y = np.meshgrid(m["c1"], m["c5"])
        filled = ax.contourf(X, Y, m[key], levels=levels, cmap="viridis")
        line = ax.contour(X, Y, m[key], levels=[target_pct], colors="white", linewidths=1.8)
        ax.clabel(line, fmt=f"{target_pct:g} %%", fontsize=8)
        outside = np.where(m["verified"], np.nan, 1.0)
        ax.contourf(X, Y, outside, levels=[0.5, 1.5], colors="none", hatches=["//"])
        if len(m["points"]):
            ax.plot(m["points"][:, 0], m["points"][:, 1], "o", color="tab:red", label="budget's points")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("c1 (kPa)")
        ax.set_ylabel("c5 (kPa)")
        ax.set_title(f"{name} (hatched: outside the verified points)", fontsize=9)
        ax.legend(fontsize=7, loc="lower right")
    fig.colorbar(
        filled, ax=axes[0].tolist(), label=f"{key.replace('_pct', '').replace('_', ' ')} 95 % half-width (%)"
    )
    if title:
        fig.suptitle(title, fontsize=10)
    return fig
