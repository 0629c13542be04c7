"""A model's responses beside the data: force against depth, the surface's displacement maps,
and a surrogate's predictions against the FE runs."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure


def force_depth_figure(depth, curves: dict, errors=None, title: str = "") -> Figure:
    """Force against depth: the first curve as measured points, the rest as lines.

    Parameters
    ----------
    depth : array_like
        Depths, mm.
    curves : dict
        Label -> forces (mN) at ``depth``; the first is drawn as measured points.
    errors : array_like, optional
        Error bars of the first curve, mN.
    title : str, default ""
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The plot.

    Examples
    --------
    >>> from indentation_studio.studio import force_depth_figure
    >>> fig = force_depth_figure([0.5, 1.0], {"measured": [1.0, 2.5], "model": [1.1, 2.4]})
    """
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
    return fig


def displacement_maps_figure(top_xyz: np.ndarray, u: np.ndarray, title: str = "") -> Figure:
    """Top-surface displacement maps (ux, uy, uz) of one step over the full field.

    The quarter model is mirrored by its symmetry planes; the fiber direction (+y) is marked.

    Parameters
    ----------
    top_xyz : numpy.ndarray
        (nodes, 3) the quarter model's top nodes, mm.
    u : numpy.ndarray
        (nodes, 3) their displacements at the step, mm.
    title : str, default ""
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        Three maps.
    """
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
    return fig


def parity_figure(pairs: dict, title: str = "") -> Figure:
    """Surrogate against FE at held-out points: one parity panel per quantity.

    Parameters
    ----------
    pairs : dict
        ``{label: (fe, surrogate)}``: the FE and surrogate values of one quantity.
    title : str, default ""
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        One panel per entry, with the line of equality.
    """
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
    return fig
