"""A campaign's figures: its points over the (c1, c5) box with their state, and the block mesh."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.figure import Figure


def campaign_figure(index: pd.DataFrame, data=None, points=None, title: str = "") -> Figure:
    """A campaign at a glance: its design over (c1, c5) and the force against depth of a few points.

    Each done point of the design is coloured by its wall time, failed points are red crosses and
    pending ones hollow; the points whose force is drawn are circled in their curve's colour.

    Parameters
    ----------
    index : pandas.DataFrame
        The store's index (``CampaignStore.index``, or ``index.parquet`` read with pandas): one row
        per point with ``point``, ``c1``, ``c5``, ``status`` and ``wall_s``.
    data : CampaignData, optional
        The done points' forces (:func:`campaign.load_campaign`); without it, the design alone.
    points : sequence of int, optional
        The points whose force is drawn; default the done points nearest the corners of the
        design's box and its centre.
    title : str, default ""
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The design (left) and, with ``data``, the force-depth curves (right).

    Examples
    --------
    >>> import pandas as pd
    >>> from indentation_studio.studio import campaign_figure
    >>> index = pd.DataFrame({"point": [0, 1], "c1": [2.0, 8.0], "c5": [100.0, 400.0],
    ...                       "status": ["done", "failed"], "wall_s": [1.9, None]})
    >>> fig = campaign_figure(index)
    """
    status = index["status"].astype(str).to_numpy()
    c1, c5 = index["c1"].to_numpy(float), index["c5"].to_numpy(float)
    done = status == "done"
    ncols = 1 if data is None else 2
    fig, axes = plt.subplots(1, ncols, figsize=(5.8 * ncols, 4.4), constrained_layout=True, squeeze=False)
    ax = axes[0, 0]
    if done.any():
        dots = ax.scatter(c1[done], c5[done], c=index["wall_s"].to_numpy(float)[done], s=36, cmap="viridis")
        fig.colorbar(dots, ax=ax, label="wall time per point (s)")
    for state, style in (
        ("failed", {"marker": "x", "color": "tab:red", "s": 48}),
        ("pending", {"marker": "o", "facecolors": "none", "edgecolors": "0.5", "s": 36}),
    ):
        if (status == state).any():
            ax.scatter(
                c1[status == state],
                c5[status == state],
                label=f"{state} ({(status == state).sum()})",
                **style,
            )
    ax.set_xlabel("c1 (kPa)")
    ax.set_ylabel("c5 (kPa)")
    ax.set_title(f"design: {done.sum()} of {len(status)} points done")
    ax.grid(alpha=0.3)
    if data is not None:
        row = {int(p): k for k, p in enumerate(data.points)}
        chosen = [int(p) for p in (_corner_points(data) if points is None else points)]
        curves = axes[0, 1]
        for j, p in enumerate(chosen):
            k = row[p]
            label = f"point {p}: c1 = {data.theta[k, 0]:g}, c5 = {data.theta[k, 1]:g} kPa"
            curves.plot(data.depth, data.force[k], "o-", ms=3, color=f"C{j}", label=label)
            ax.scatter(data.theta[k, 0], data.theta[k, 1], s=160, facecolors="none", edgecolors=f"C{j}", lw=2)
        curves.set_xlabel("indentation depth (mm)")
        curves.set_ylabel("indenter force, whole specimen (mN)")
        curves.set_title("force against depth")
        curves.grid(alpha=0.3)
        curves.legend(fontsize=8)
    if (status != "done").any():
        ax.legend(fontsize=8, loc="upper right")
    if title:
        fig.suptitle(title)
    return fig


def _corner_points(data) -> list[int]:
    """The done points nearest the corners of their (c1, c5) box and its centre, each once."""
    theta = np.asarray(data.theta, float)[:, :2]
    lo, span = theta.min(axis=0), np.ptp(theta, axis=0)
    unit = (theta - lo) / np.where(span > 0, span, 1.0)
    chosen: list[int] = []
    for target in ((0, 0), (1, 0), (0, 1), (1, 1), (0.5, 0.5)):
        p = int(data.points[np.argmin(np.linalg.norm(unit - target, axis=1))])
        if p not in chosen:
            chosen.append(p)
    return chosen


def mesh_figure(nodes: np.ndarray, elements: np.ndarray, title: str = "") -> Figure:
    """The block mesh: the edges of the element faces on the top and the two symmetry planes, in 3D.

    Parameters
    ----------
    nodes : numpy.ndarray
        (n, 3) node coordinates, mm.
    elements : numpy.ndarray
        (ne, 8) hex8 elements.
    title : str, default ""
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The 3D plot.
    """
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
    return fig
