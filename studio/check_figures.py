"""Figures of the data check (``indent-studio check``): each function returns a matplotlib Figure
drawn from an experiment, its registration and its :class:`DataCheck` (made without pyplot, so no
backend or global figure state is touched); the caller saves it."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from ..inference.experiment.data import ExperimentData
from ..inference.experiment.data_check import DataCheck
from ..inference.experiment.processing import RegisteredDIC, fit_sphere


def hold_fits_figure(exp: ExperimentData, check: DataCheck) -> Figure:
    """Every hold's readings against time (holds placed one after another), its eq. 9 fit and
    f_inf (top), and the fit's residual in percent of f_inf (bottom)."""
    fig = Figure(figsize=(11, 6), layout="constrained")
    top, bottom = fig.subplots(2, 1, sharex=True, height_ratios=(3, 1.3))
    offset = 0.0
    for h in check.holds:
        g = exp.force[exp.force["step"] == h.step]
        t, f = g["time_s"].to_numpy(float), g["force_mN"].to_numpy(float)
        tt = np.linspace(t.min(), t.max(), 60)

        def model(x: np.ndarray, h=h, t0: float = float(t.min())) -> np.ndarray:
            return h.amplitude_mN * np.exp(-(x - t0) / h.tau_s) + h.f_inf_mN

        colour = "C0" if h.step % 2 else "C1"
        top.plot(offset + t, f, ".", ms=2.5, color=colour)
        top.annotate(
            str(h.step),
            xy=(offset + t.min(), f.max()),
            xytext=(0, 3),
            textcoords="offset points",
            fontsize=6,
            color=colour,
        )
        top.plot(offset + tt, model(tt), "-", lw=1, color="k")
        top.plot([offset + t.min(), offset + t.max()], [h.f_inf_mN] * 2, "--", lw=0.8, color="C3")
        bottom.plot(offset + t, 100.0 * (f - model(t)) / abs(h.f_inf_mN), ".", ms=2.5, color=colour)
        offset += t.max() - t.min() + 0.15 * max(t.max() - t.min(), 1.0)
    if check.excluded_steps:
        top.annotate(
            "left out: step " + ", ".join(map(str, check.excluded_steps)),
            xy=(0.99, 0.03),
            xycoords="axes fraction",
            color="C3",
            fontsize=9,
            ha="right",
        )
    top.plot([], [], "k-", label="eq. 9 fit")
    top.plot([], [], "--", color="C3", label=r"$f_\infty$")
    top.set_ylabel("force (mN)")
    top.set_title("force during each hold (holds placed end to end), eq. 9 fit and static force")
    top.legend(fontsize=8, loc="upper left")
    bottom.axhline(0.0, color="k", lw=0.6)
    bottom.set_ylabel(r"residual (% of $f_\infty$)")
    bottom.set_xlabel("time within the holds, placed end to end (s)")
    return fig


def dic_coverage_figure(exp: ExperimentData, check: DataCheck, dic: RegisteredDIC) -> Figure:
    """Correlated DIC points at four steps in the model frame, coloured by uz, with the indenter's
    shadow (contact radius) and the field of view; the points per step below."""
    steps = sorted({1, max(1, exp.steps // 3), max(1, 2 * exp.steps // 3), exp.steps})
    fig = Figure(figsize=(12, 7), layout="constrained")
    grid = fig.add_gridspec(2, len(steps), height_ratios=(2.2, 1))
    finite = np.isfinite(dic.u[..., 2])
    vmax = float(np.nanmax(np.abs(dic.u[..., 2]))) if finite.any() else 1.0
    phi = np.linspace(0, 2 * np.pi, 200)
    maps = []
    for j, k in enumerate(steps):
        ax = fig.add_subplot(grid[0, j])
        maps.append(ax)
        ok = np.isfinite(dic.u[k - 1]).all(axis=1)
        sc = ax.scatter(
            dic.xyz[ok, 0],
            dic.xyz[ok, 1],
            c=dic.u[k - 1, ok, 2],
            s=1.5,
            cmap="viridis",
            vmin=-vmax,
            vmax=0.2 * vmax,
        )
        c = check.coverage[k - 1]
        for radius, style, width, label in (
            (c.shadow_radius_mm, "r-", 1.0, f"contact radius {c.shadow_radius_mm:.2f} mm"),
            (check.field_of_view_mm, "k--", 0.8, f"field of view {check.field_of_view_mm:.1f} mm"),
        ):
            ax.plot(radius * np.cos(phi), radius * np.sin(phi), style, lw=width, label=label)
        ax.set_aspect("equal")
        ax.set_title(f"step {k} ({c.depth_mm:g} mm): {c.points} points", fontsize=9)
        ax.set_xlabel("x (mm)")
        if j == 0:
            ax.set_ylabel("y, along the fibers (mm)")
        ax.legend(fontsize=6, loc="lower left")
    fig.colorbar(sc, ax=maps, shrink=0.8, label="uz (mm)", location="right")
    ax = fig.add_subplot(grid[1, :])
    k = [c.step for c in check.coverage]
    ax.bar(
        k, [c.points for c in check.coverage], color=["C3" if s in check.excluded_steps else "C0" for s in k]
    )
    ax.set_xlabel("step")
    ax.set_ylabel("correlated points")
    ax2 = ax.twinx()
    ax2.plot(k, [c.shadow_radius_mm for c in check.coverage], "r.-", lw=1, label="contact radius")
    ax2.plot(k, [c.innermost_point_mm for c in check.coverage], "k.-", lw=1, label="innermost point")
    ax2.set_ylabel("radius from the axis (mm)")
    ax2.legend(fontsize=8, loc="lower right")
    ax.set_title("DIC coverage per step (red bars: excluded steps)", fontsize=9)
    return fig


def sphere_fit_figure(exp: ExperimentData, check: DataCheck) -> Figure:
    """The indenter points seen from above coloured by their distance from the fitted sphere, and
    the histogram of that residual beside the DIC noise."""
    centre, radius = fit_sphere(exp.indenter_xyz)
    rel = exp.indenter_xyz - centre
    resid = np.linalg.norm(rel, axis=1) - radius
    fig = Figure(figsize=(11, 4.6), layout="constrained")
    a, b = fig.subplots(1, 2)
    lim = float(np.abs(resid).max()) or 1.0
    sc = a.scatter(rel[:, 0], rel[:, 1], c=resid, cmap="coolwarm", vmin=-lim, vmax=lim, s=8)
    phi = np.linspace(0, 2 * np.pi, 200)
    a.plot(radius * np.cos(phi), radius * np.sin(phi), "k-", lw=0.8)
    a.set_aspect("equal")
    a.set_xlabel("x - centre (mm)")
    a.set_ylabel("y - centre (mm)")
    a.set_title(f"indenter points: sphere R = {radius:.4g} mm (declared {exp.radius:g})", fontsize=9)
    fig.colorbar(sc, ax=a, label="|x - c| - R (mm)")
    b.hist(resid, bins=30, color="C0")
    noise = float(np.mean(check.dic_noise_mm))
    for v in (-noise, noise):
        b.axvline(v, color="C3", ls="--", lw=1)
    b.set_xlabel("|x - c| - R (mm)")
    b.set_ylabel("points")
    b.set_title(
        f"residual RMS {check.sphere_residual_rms_mm:.3g} mm; red: +- DIC noise {noise:.3g} mm", fontsize=9
    )
    return fig


def registration_figure(exp: ExperimentData, check: DataCheck, dic: RegisteredDIC) -> Figure:
    """Left: the DIC points on the top face (the DIC frame leveled: its own frame when its z is
    the face's normal), the indentation point and the fiber direction (used, and from the strain
    field; both angles in that leveled frame). Right: the FE top nodes of the quarter model with DIC data
    and those obscured, over the registered DIC points."""
    fig = Figure(figsize=(12, 5.6), layout="constrained")
    a, b = fig.subplots(1, 2)
    # the top face seen square on: the DIC frame leveled (the identity when its z is the face's
    # normal), the origin kept where the DIC frame has it
    L = dic.frame.leveling if dic.frame is not None else np.eye(3)
    face = exp.dic_xyz @ L.T
    a.scatter(face[:, 0], face[:, 1], s=0.5, color="0.6")
    o = L @ dic.origin
    a.plot(o[0], o[1], "r+", ms=14, mew=2, label="indentation point")
    span = 0.5 * float(np.ptp(face[:, :2], axis=0).max())
    for angle, style, label in (
        (
            check.fiber_angle_deg,
            "C3-",
            "fibers ("
            + ("estimated" if check.fiber_angle_estimated else "declared")
            + f") {check.fiber_angle_deg:.1f} deg",
        ),
        (
            check.fiber_angle_from_strain_deg,
            "C2--",
            f"strain field {check.fiber_angle_from_strain_deg or 0:.1f} deg",
        ),
    ):
        if angle is None:
            continue
        d = np.array([np.cos(np.radians(angle)), np.sin(np.radians(angle))]) * span
        a.plot([o[0] - d[0], o[0] + d[0]], [o[1] - d[1], o[1] + d[1]], style, lw=1.5, label=label)
    a.set_aspect("equal")
    tilt = dic.frame.tilt_deg if dic.frame is not None else 0.0
    a.set_xlabel("x, DIC frame leveled (mm)" if tilt > 1e-6 else "x, DIC frame (mm)")
    a.set_ylabel("y, DIC frame leveled (mm)" if tilt > 1e-6 else "y, DIC frame (mm)")
    a.set_title(
        f"registration: the top face, leveled from the DIC frame (tilted {tilt:.3g} deg)"
        if tilt > 1e-6
        else "registration in the DIC frame",
        fontsize=9,
    )
    a.legend(fontsize=8, loc="lower left")
    b.scatter(dic.xyz[:, 0], dic.xyz[:, 1], s=0.3, color="0.75")
    xy = np.asarray(check.node_xy)
    m = np.asarray(check.node_measured, bool)
    b.plot(xy[m, 0], xy[m, 1], "o", ms=3.5, color="C0", label=f"{m.sum()} nodes with DIC data")
    b.plot(xy[~m, 0], xy[~m, 1], "x", ms=4, color="C3", label=f"{(~m).sum()} nodes obscured")
    lim = min(float(np.abs(xy).max()), 1.2 * check.field_of_view_mm)
    b.set_xlim(-0.05 * lim, lim)
    b.set_ylim(-0.05 * lim, lim)
    b.set_aspect("equal")
    b.set_xlabel("x, model frame (mm)")
    b.set_ylabel("y, along the fibers (mm)")
    b.set_title(f"FE top nodes ('{check.mesh}' mesh, quarter model)", fontsize=9)
    b.legend(fontsize=8, loc="upper right")
    return fig
