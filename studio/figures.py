"""Figures of the studio, in the style of corner.py: each function returns a matplotlib Figure (shown
inline in a notebook); saving is the caller's (:func:`save_figure`), and the backend is chosen by
whoever runs them (the CLI's entry point sets Agg). The numerics come from the packages."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.colors import LogNorm
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle
from matplotlib.ticker import ScalarFormatter

from ..atomic_write import atomic_write
from ..design.objective_over_plane import ObjectiveMap
from ..forward.material import equibiaxial_stress_incompressible


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


def corner_figure(
    posterior,
    fit_theta=None,
    fit_hessian=None,
    s: float | None = None,
    truth=None,
    *,
    bounds=None,
    not_identified: tuple[str, ...] = (),
) -> Figure:
    """Corner plot (corner package) of posterior samples, with the fit, its bounds and eq. 6 ellipse overlaid.

    Parameters
    ----------
    posterior : Posterior
        The samples and their parameters.
    fit_theta : array_like, optional
        The fit, kPa (red lines).
    fit_hessian : numpy.ndarray, optional
        The fit's Hessian in theta_bar = theta / theta_hat; with ``s``, its eq. 6 certainty
        ellipse is drawn in the (c1, c5) panel (two parameters only).
    s : float, optional
        Eq. 6's s of the ellipse.
    truth : array_like, optional
        The truth of a synthetic experiment, when known (green); the parameters it lacks (mu of
        a perfect-stick experiment) are left unmarked.
    bounds : array_like, optional
        (q, 2) the fit's 95 % bounds of the first q parameters, as the fit reports them (shaded on
        the marginals, a box in the pairs), so that the plot shows what the fit's bounds hold.
    not_identified : tuple of str, default ()
        Parameters the data do not identify (a marginal that reaches its prior's end): said on
        their panel, their fit line not drawn.

    Returns
    -------
    matplotlib.figure.Figure
        The corner plot.
    """
    import corner

    labels = [name if name == "mu" else f"{name} (kPa)" for name in posterior.parameters]  # mu: no unit
    span = np.percentile(posterior.samples, [0.5, 99.5], axis=0).T  # corner's own default range
    if truth is not None:  # (c1, c5) of a stick experiment beside a posterior with mu: mu's unknown
        truth = [float(v) for v in truth] + [None] * (len(labels) - len(truth))
        known = np.array([np.nan if v is None else v for v in truth])
        # widened so that a truth far from the samples is seen, not clipped
        span = np.column_stack([np.fmin(span[:, 0], known), np.fmax(span[:, 1], known)])
    pad = 0.05 * (span[:, 1] - span[:, 0])
    fig = corner.corner(
        posterior.samples,
        range=list(zip(span[:, 0] - pad, span[:, 1] + pad, strict=True)),
        labels=labels,
        quantiles=[0.025, 0.5, 0.975],
        show_titles=True,
        title_fmt=".4g",
        truths=None
        if fit_theta is None
        else [
            None if name in not_identified else float(v)
            for name, v in zip(posterior.parameters, fit_theta, strict=False)
        ],
        truth_color="tab:red",
    )
    n = len(labels)
    grid = np.array(fig.axes).reshape(n, n)
    if bounds is not None:
        b = np.asarray(bounds, float)
        for i in range(min(len(b), n)):
            if posterior.parameters[i] in not_identified:
                continue
            grid[i, i].axvspan(b[i, 0], b[i, 1], color="tab:red", alpha=0.12, lw=0)
            for j in range(i):
                if posterior.parameters[j] in not_identified:
                    continue
                grid[i, j].add_patch(
                    Rectangle(
                        (b[j, 0], b[i, 0]),
                        b[j, 1] - b[j, 0],
                        b[i, 1] - b[i, 0],
                        fill=False,
                        ec="tab:red",
                        ls="--",
                    )
                )
        grid[0, 0].plot([], [], color="tab:red", alpha=0.4, lw=6, label="fit's 95 % bounds")
        grid[0, 0].legend(fontsize=7, loc="upper right")
    for i, name in enumerate(posterior.parameters):
        if name in not_identified:
            grid[i, i].set_title(f"{name}: not identified", fontsize=10, color="tab:red")
            grid[i, i].text(
                0.5,
                0.5,
                f"{name} not identified:\nits 95 % interval\nreaches the prior's end",
                transform=grid[i, i].transAxes,
                ha="center",
                va="center",
                fontsize=8,
                color="tab:red",
                bbox={"fc": "white", "ec": "tab:red", "alpha": 0.85},
            )
    if truth is not None:
        corner.overplot_lines(fig, truth, color="tab:green", lw=1.5)
        if None not in truth:
            corner.overplot_points(fig, [truth], marker="s", color="tab:green")
        fig.axes[0].plot([], [], color="tab:green", label="truth")
        fig.axes[0].legend(fontsize=7, loc="upper left")
    if fit_theta is not None and fit_hessian is not None and s is not None and len(labels) == 2:
        e = certainty_ellipse(fit_hessian, s) * np.asarray(fit_theta)  # back to kPa
        ax = fig.axes[len(labels)]  # lower-left panel: c5 against c1
        ax.plot(e[:, 0], e[:, 1], color="tab:red", lw=1.5, label="Hessian ellipse (eq. 6)")
        ax.legend(fontsize=7, loc="upper right")
    return fig


def posterior_corner_figure(post, *, fit=None, truth=None) -> Figure:
    """The corner plot of an experiment's posterior: its samples, the fit, its bounds and ellipse.

    Parameters
    ----------
    post : ExperimentPosterior
        The posterior (:func:`inference.posterior.workflow.sample_posterior_for`).
    fit : FitResult, optional
        The fit whose Hessian and s draw the eq. 6 ellipse; default the fit the posterior was
        sampled on (``post.fit``).
    truth : array_like, optional
        The truth of a synthetic experiment, when known.

    Returns
    -------
    matplotlib.figure.Figure
        The corner plot (:func:`corner_figure`).
    """
    fit = post.fit if fit is None else fit
    return corner_figure(
        post.posterior,
        post.marker,
        fit.hessian,
        fit.s,
        truth=truth,
        bounds=post.fit_bounds,
        not_identified=post.not_identified,
    )


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
    :class:`inference.experiment.composite.CompositeComparison`."""
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


def save_figure(fig: Figure, path: str | Path, dpi: int = 130) -> Path:
    """Write ``fig`` as a PNG at ``path`` (atomically) and close it.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    path : str or pathlib.Path
        The PNG file.
    dpi : int, default 130
        Resolution.

    Returns
    -------
    pathlib.Path
        The file written.
    """
    path = Path(path)
    try:
        atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=dpi, format=path.suffix.lstrip(".") or "png"))
    finally:
        plt.close(fig)
    return path


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
