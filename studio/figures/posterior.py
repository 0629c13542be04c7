"""The posterior's corner plot, with the fit, its bounds and eq. 6's ellipse over the samples."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from .design import certainty_ellipse


def corner_figure(
    posterior,
    fit_theta=None,
    fit_hessian=None,
    s: float | None = None,
    truth=None,
    *,
    bounds=None,
    not_identified: tuple[str, ...] = (),
    log_axes: tuple[str, ...] = (),
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
    log_axes : tuple of str, default ()
        Parameters drawn on a log axis (mu under a log-uniform prior: its prior then looks flat,
        as it is, instead of piling at the range's low end as if the data pointed there).

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
    logged = np.array([name in log_axes for name in posterior.parameters])
    pad = 0.05 * (span[:, 1] - span[:, 0])
    ranges = np.column_stack([span[:, 0] - pad, span[:, 1] + pad])
    ratio = (span[:, 1] / np.where(logged, span[:, 0], 1.0)) ** 0.05  # the same 5 % in log
    ranges[logged] = np.column_stack([span[logged, 0] / ratio[logged], span[logged, 1] * ratio[logged]])
    fig = corner.corner(
        posterior.samples,
        range=[tuple(r) for r in ranges],
        axes_scale=["log" if flag else "linear" for flag in logged],
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
        log_axes=("mu",) if post.friction.mode == "marginalise" else (),
    )
