"""A surrogate fitted to FE runs it was not trained on, noise-free: its own error in the parameters.

A surrogate keeps its output-space errors at held-out points (``surrogate.emulation_error``) and a
fit pushes them through to first order. That answers how far an output error moves a fit; it
cannot say what the surrogate does with outputs of a kind it never saw. Here each run of a campaign
is taken as an experiment with no noise, its whole top surface read as the fit reads DIC (eq. 4a,
4b, 5; the fit's objective), and fitted on the surrogate as a plain fit is made (mu free over the
surrogate's range where mu is one of its parameters, from three starts in mu,
:func:`~indentation_studio.inference.fit.friction.fit_on_surrogate_with_mu`). The fit's distance
from the run's parameters is the surrogate's error where it matters.

Issue 57: a surrogate whose discrepancy (low level to level 3) was learned at the stick fitted
level 3's own record made with mu = 1 with c5 3 % low, where its held-out errors near the fit said
0.7 %. Level-3 runs with mu over the box, fitted here, measure how that discrepancy changes with
friction (docs/validation/model-error.md).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...design.friction_treatment import FrictionTreatment
from ...design.objective import PAPER_WEIGHTS, Objective, check_weights
from ...surrogate.training import training_data
from ...surrogate.training_set import TrainingData
from .friction import fit_on_surrogate_with_mu
from .inverse_fit import PAPER_START, fit_parameters

__all__ = ["RunRefit", "refit_campaign", "refit_runs", "refit_summary"]

#: Top nodes of a campaign and a surrogate closer than this are the same nodes, mm.
SAME_NODE_MM = 1e-6


@dataclass(frozen=True)
class RunRefit:
    """One run fitted on the surrogate.

    Attributes
    ----------
    parameters : tuple of str
        The run's parameters (c1, c5 and, with friction, mu).
    truth : numpy.ndarray
        (p,) the run's parameters.
    fitted_parameters : tuple of str
        The fit's parameters (the surrogate's).
    fit : numpy.ndarray
        (k,) the fit.
    F : float
        The objective at the fit (eq. 5).
    """

    parameters: tuple[str, ...]
    truth: np.ndarray
    fitted_parameters: tuple[str, ...]
    fit: np.ndarray
    F: float

    def error_pct(self, name: str) -> float:
        """The fit's error in ``name``, percent of the run's value (NaN where the run has none).

        Parameters
        ----------
        name : str
            "c1", "c5" or "mu".

        Returns
        -------
        float
        """
        if name not in self.parameters or name not in self.fitted_parameters:
            return float("nan")
        truth = float(self.truth[self.parameters.index(name)])
        return 100.0 * (float(self.fit[self.fitted_parameters.index(name)]) / truth - 1.0)

    def to_dict(self) -> dict:
        """The run, the fit and the errors, for JSON.

        Returns
        -------
        dict
        """
        out = {f"{k}_true": float(v) for k, v in zip(self.parameters, self.truth, strict=True)}
        out |= {f"{k}_fit": float(v) for k, v in zip(self.fitted_parameters, self.fit, strict=True)}
        out |= {f"{k}_error_pct": self.error_pct(k) for k in ("c1", "c5", "mu") if k in self.parameters}
        return out | {"F": float(self.F)}


def refit_runs(
    surrogate,
    data: TrainingData,
    *,
    weights=PAPER_WEIGHTS,
    reading: str = "fit",
    progress: Callable[[int, int], None] | None = None,
) -> list[RunRefit]:
    """Fit each run of ``data`` on ``surrogate`` as a noise-free experiment (module docstring).

    Parameters
    ----------
    surrogate : FieldSurrogate
        The surrogate (over (c1, c5) or (c1, c5, mu)), predicting on ``data``'s top nodes.
    data : TrainingData
        The runs (e.g. a campaign of the high fidelity with friction), over (c1, c5) or
        (c1, c5, mu).
    weights : array_like, default PAPER_WEIGHTS
        eta of eq. 5.
    reading : str, default "fit"
        How eq. 4 is read (:class:`~indentation_studio.design.objective.Objective`).
    progress : callable, optional
        ``progress(done, total)`` after each run.

    Returns
    -------
    list of RunRefit
        One per run, in ``data``'s order.

    Raises
    ------
    ValueError
        If the runs are of another test (steps, depths) or on other top nodes than the
        surrogate's, or their parameters are not the surrogate's first ones.
    """
    eta = check_weights(weights)
    names, fitted = tuple(data.parameters), tuple(surrogate.parameters)
    if names != fitted[: len(names)]:
        raise ValueError(f"the runs' parameters {names} are not the surrogate's {fitted} (or its first ones)")
    depth = np.asarray(surrogate.depth, float)
    if depth.shape != np.shape(data.depth) or not np.allclose(depth, data.depth):
        raise ValueError(
            f"the runs ({len(data.depth)} steps to {data.depth[-1]:g} mm) are of another test than the "
            f"surrogate's ({len(depth)} steps to {depth[-1]:g} mm)"
        )
    top = np.asarray(surrogate.top_xyz, float)
    if top.shape != data.top_xyz.shape or np.abs(top - data.top_xyz).max() > SAME_NODE_MM:
        raise ValueError(
            f"the runs' {len(data.top_xyz)} top nodes are not the surrogate's {len(top)}: refit runs of "
            "the mesh the surrogate predicts on (a multi-fidelity surrogate's high-fidelity mesh)"
        )
    radius = float(surrogate.meta["campaign"]["model"]["indenter"]["radius"])
    out = []
    for k in range(data.n):
        objective = Objective(data.force[k], data.displacement[k], top, radius, reading=reading)
        if "mu" in fitted:
            lo, hi = float(surrogate.scaler.lo[2]), float(surrogate.scaler.hi[2])
            fit = fit_on_surrogate_with_mu(
                objective, surrogate, eta, FrictionTreatment("marginalise"), (lo, hi)
            )
        else:
            box = (np.asarray(surrogate.scaler.lo, float), np.asarray(surrogate.scaler.hi, float))
            fit = fit_parameters(objective, surrogate, eta, PAPER_START, box=box)
        out.append(
            RunRefit(names, np.asarray(data.theta[k], float), fitted, np.asarray(fit.theta, float), fit.F)
        )
        if progress is not None:
            progress(k + 1, data.n)
    return out


def refit_summary(refits: list[RunRefit]) -> dict:
    """The largest and the 95th percentile of |error| in each parameter over the runs.

    Parameters
    ----------
    refits : list of RunRefit
        :func:`refit_runs`'s result.

    Returns
    -------
    dict
        ``{name: {"max_abs_pct", "p95_abs_pct", "mean_pct"}}`` for c1, c5 (and mu where the runs
        have it), and ``runs``.
    """
    summary: dict = {"runs": len(refits)}
    for name in ("c1", "c5", "mu"):
        errors = np.array([r.error_pct(name) for r in refits])
        errors = errors[np.isfinite(errors)]
        if errors.size:
            summary[name] = {
                "max_abs_pct": float(np.abs(errors).max()),
                "p95_abs_pct": float(np.quantile(np.abs(errors), 0.95)),
                "mean_pct": float(errors.mean()),
            }
    return summary


def refit_campaign(
    surrogate,
    campaign: str | Path,
    runs_dir: str | Path = "runs",
    *,
    weights=PAPER_WEIGHTS,
    progress: Callable[[int, int], None] | None = None,
) -> dict:
    """Every done run of a campaign fitted on the surrogate (:func:`refit_runs`), and the summary.

    Parameters
    ----------
    surrogate : FieldSurrogate
        The surrogate.
    campaign : str or pathlib.Path
        The campaign's name under ``runs_dir`` (or its folder).
    runs_dir : str or pathlib.Path, default "runs"
        Where campaigns live.
    weights : array_like, default PAPER_WEIGHTS
        eta of eq. 5.
    progress : callable, optional
        ``progress(done, total)`` after each run.

    Returns
    -------
    dict
        ``refits`` (one :meth:`RunRefit.to_dict` per run) and ``summary`` (:func:`refit_summary`).
    """
    refits = refit_runs(surrogate, training_data(campaign, runs_dir), weights=weights, progress=progress)
    return {"refits": [r.to_dict() for r in refits], "summary": refit_summary(refits)}
