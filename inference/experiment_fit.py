"""The inverse fit of a measured experiment (paper 2.8.2): Levenberg-Marquardt on the surrogate,
then on the FE solver with its exact sensitivities, bounds from eq. 6 to 8; optionally the mesh check
at the fit (:mod:`inference.budgets.mesh_check`) and the fit carried to the finer mesh."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from ..atomic_write import atomic_write_json
from ..design.friction_treatment import (
    DEFAULT_MU_RANGE,
    FixedParameter,
    FrictionTreatment,
    friction_bounds,
)
from ..design.objective import PAPER_WEIGHTS
from ..forward.predictor import FESolverPredictor
from ..forward.solver import SimulationError
from ..surrogate.base import SPARSE_GAP, FieldSurrogate
from ..surrogate.error_budgets import budget_at, surrogate_error_budget
from .adequacy import fit_adequacy, training_box_ends
from .budgets.check import budget_status
from .budgets.mesh_check import MeshCheck, check_mesh_at
from .budgets.model_error import (
    ModelError,
    budget_correction,
    combined_pct,
    emulation_error_pct,
    has_high_fidelity_level,
    model_error_at,
    model_error_scope,
    with_emulation_error,
    with_processing_error,
)
from .experiment.data import ExperimentData
from .experiment.processing_error import REGISTRATION_MM, processing_error_at
from .fit.confirm_stage import FitConfirmation, confirm_fit
from .fit.inputs import FitInputs, prepare_fit
from .fit.inverse_fit import (
    PAPER_F_STOP,
    PAPER_START,
    FitResult,
    fit_parameters,
    gauss_newton_refine,
    residuals_at,
)

__all__ = [
    "FE_STAGES",
    "ExperimentFit",
    "check_parameter_order",
    "default_friction",
    "fit_experiment",
    "fit_on_surrogate_with_mu",
    "interval_is_whole_range",
    "model_error_with_mu",
    "mu_is_identified",
    "mu_model_error_pct",
    "mu_reach_by_model_error",
    "resolved_fe_stage",
    "surrogate_with_mu",
]

#: What follows the fit on the surrogate (``fit_experiment(fe_stage=...)``): ``confirm``, one FE run
#: at the fit and the Gauss-Newton step it points to (:mod:`inference.fit.confirm_stage`); ``fit``,
#: Levenberg-Marquardt on the FE model (paper 2.8.2; minutes with mu); ``none``; ``auto``,
#: ``confirm`` on a surrogate trained with mu and ``fit`` on one without (its FE stage is what
#: brings mu in, or refines the stick's fit).
FE_STAGES = ("auto", "confirm", "fit", "none")


@dataclass
class ExperimentFit:
    """A fit of an experiment: the surrogate stage, the final (FE-refined) fit, and its checks.

    Attributes
    ----------
    inputs : FitInputs
        The experiment, surrogate, FE model and objective.
    surrogate_fit : FitResult
        The fit on the surrogate.
    fit : FitResult
        The FE fit when refined, else the surrogate fit.
    refined : bool
        Whether the FE stage ran.
    mesh_check : MeshCheck or None
        The mesh check at the fit, when asked for.
    check_mesh : str or None
        The preset the mesh check solved on.
    model_error : ModelError or None
        The model-error parts (a high-fidelity level or an error budget).
    friction : FrictionTreatment
        How mu was treated.
    mu_range : tuple of float or None
        identify / marginalise: the range mu was kept inside.
    mu_reach : dict of str to bool or None
        Does mu's certainty region reach the range's ends.
    mu_reach_notes : dict of str to str
        An end not checked, and why.
    restarts : list of dict
        Fits again from a better point found at an end.
    adequacy : Adequacy or None
        The chi-square test: can the model explain the data.
    adequacy_note : str or None
        Why the adequacy test was not made.
    confirmation : FitConfirmation or None
        The FE confirmation at a fit on the surrogate (``fe_stage="confirm"``).
    """

    inputs: FitInputs
    surrogate_fit: FitResult
    fit: FitResult  # the FE fit when refined, else the surrogate fit
    refined: bool
    mesh_check: MeshCheck | None = None
    check_mesh: str | None = None  # the preset the mesh check solved on
    model_error: ModelError | None = None  # with a high-fidelity level: the model-error parts
    friction: FrictionTreatment = field(default_factory=FrictionTreatment)
    mu_range: tuple[float, float] | None = None  # identify / marginalise: mu kept inside
    mu_reach: dict[str, bool] | None = None  # does mu's certainty region reach the range's ends
    mu_reach_notes: dict[str, str] = field(default_factory=dict)  # an end not checked, and why
    restarts: list[dict] = field(default_factory=list)  # fits again from a better point found at an end
    # the model's own errors as a part of mu's 95 % half-width, percent (mu_model_error_pct: the
    # surrogate's held-out errors, the discrepancy's uncertainty): they can move mu far more than (c1, c5)
    mu_model_pct: float | None = None
    adequacy: object | None = None  # inference.adequacy.Adequacy: can the model explain the data
    adequacy_note: str | None = None  # why the adequacy test was not made
    confirmation: FitConfirmation | None = None  # fe_stage "confirm": one FE run at the surrogate's fit

    @property
    def friction_bounds(self) -> dict | None:
        """With mu fitted: (c1, c5)'s bounds, mu's, the conditional ones and mu's share; else None.

        See :func:`design.friction_treatment.friction_bounds`.
        """
        if not self.friction.fits_mu:
            return None
        f = self.fit
        return friction_bounds(f.hessian, f.s, f.residual_sd, self.friction, self.mu_range, f.n_residuals)

    @property
    def _confirmed(self) -> bool:
        """Whether an FE confirmation ran and left its residuals."""
        return self.confirmation is not None and self.confirmation.residuals is not None

    @property
    def tested_fit(self) -> FitResult:
        """The fit the adequacy test reads.

        With an FE confirmation that ran: the FE model's residuals one Gauss-Newton step from the
        surrogate's fit, linearised (r + J delta: the model, not its surrogate, is what must explain
        the data, and a surrogate's miss that the step corrects is the confirmation's warning, not
        the model's inadequacy); else the final fit's own.

        Returns
        -------
        FitResult
            The final fit, with those residuals, F, Jacobian and prediction when confirmed.
        """
        if not self._confirmed:
            return self.fit
        c = self.confirmation
        r = c.residuals + c.jacobian @ np.log1p(c.shift_pct / 100.0)
        return replace(self.fit, F=float(r @ r), residuals=r, jacobian=c.jacobian, prediction=c.prediction)

    @property
    def statistical_pct(self) -> np.ndarray:
        """Eq. 6's half-widths of (c1, c5): with mu fitted, those with mu's uncertainty in them."""
        fb = self.friction_bounds
        return self.fit.bounds_pct[:2] if fb is None else np.array(fb["bounds_pct"])

    @property
    def theta(self) -> np.ndarray:
        """The fitted (c1, c5), kPa, corrected by the error budget where it corrects its model.

        The fit of the surrogate's (or FE stage's) model is ``fit.theta``; a budget moved to a finer
        reference (``inference.with_finest_reference``) brings it there, ``model_error.correction_pct``.
        mu, when fitted, is in ``fit.theta[2]`` and fit.json's 'friction'.
        """
        if self.model_error is None:
            return self.fit.theta[:2]
        return self.model_error.corrected(self.fit.theta[:2])

    @property
    def bounds_pct(self) -> np.ndarray:
        """The reported 95 % half-width of (c1, c5): statistical and, where known, model error combined."""
        return combined_pct(self.statistical_pct, self.model_error)

    @property
    def contact(self) -> str:
        """What the bounds assume of the contact, in words."""
        return self.friction.describe(self.inputs.spec.contact.describe(), self.mu_range)

    @property
    def warnings(self) -> list[str]:
        """What the fit found wrong with its own inputs, as sentences.

        E.g. a surrogate stage that ended far above the FE fit of the same model (F more than
        ``SURROGATE_MISS_RATIO`` times the FE fit's) misses these data, and a surrogate-only fit or
        a posterior on it would be wrong here.
        """
        first, final = self.surrogate_fit, self.fit
        out = []
        if self.friction.mode == "assumed" and self.inputs.spec.contact.friction is None:
            out.append(
                "the contact is assumed a perfect stick: fits of data made with mu = 0.3 put c5 28 to 34 % "
                "low, outside their bounds (README, 'Friction'); unless the stick is known to hold, fit "
                "with mu marginalised (--friction marginalise: the FE stage of a single-level surrogate, "
                "without --check-mesh, or a surrogate trained with mu)"
            )
        same_model = "mu" in self.inputs.surrogate.parameters or self.friction.mode == "assumed"
        if self.refined and same_model and final.F > 0 and first.F > SURROGATE_MISS_RATIO * final.F:
            out.append(
                f"the {self.inputs.surrogate.kind} surrogate's fit ended at F = {first.F:.4g}, the FE fit at "
                f"F = {final.F:.4g}: the surrogate misses these data (a fit on it alone, or a posterior "
                "sampled on it, would be wrong here); train it on a denser campaign around the fit"
            )
        if self.confirmation is not None:
            out.extend(self.confirmation.warnings)
        region = self.training_region
        if region is not None and region["at_box_edge"]:
            out.append(
                f"the fit sits at the edge of the surrogate's training box in {', '.join(region['at_box_edge'])}: "
                "the data may want a value outside it, which the surrogate cannot give; train on a wider box"
            )
        if region is not None and region["gap"] is not None and region["gap"] > SPARSE_GAP:
            out.append(
                f"the fit lies in a region without training points (nearest {region['gap']:.1f} median "
                "spacings away: a corner of the box, or points of the campaign that did not converge); "
                "the surrogate interpolates far there"
            )
        return out

    @property
    def training_region(self) -> dict | None:
        """Where a fit that ended on the surrogate lies in its training data.

        Returns
        -------
        dict or None
            ``at_box_edge``: the parameters at or within 0.5 % of an end of the training box
            (:func:`inference.adequacy.training_box_ends`; mu's range end is named by fit.json's
            'friction' instead); ``gap``: the distance to the
            nearest training point in median spacings
            (:meth:`surrogate.base.FieldSurrogate.training_gap`; None for a surrogate saved before
            its points were kept); ``sparse_gap``: the gap beyond which the fit says so. None
            after an FE fit.
        """
        if self.refined:
            return None
        model = self.inputs.surrogate
        ends = training_box_ends(model, self.fit.theta)
        at_edge = [model.parameters[j] for j, _ in ends if model.parameters[j] != "mu"]
        gap = float(model.training_gap(self._theta_in_surrogate())[0])
        return {"at_box_edge": at_edge, "gap": None if np.isnan(gap) else gap, "sparse_gap": SPARSE_GAP}

    def _theta_in_surrogate(self) -> np.ndarray:
        """The fit as the surrogate's full theta (mu held: put back)."""
        theta = self.fit.theta
        if "mu" in self.inputs.surrogate.parameters and theta.size == 2:
            theta = np.append(theta, self.friction.value)
        return theta[None, :]

    def to_dict(self) -> dict:
        """fit.json: theta, bounds (statistical only unless a mesh check is present), provenance."""
        final, inputs = self.fit, self.inputs
        first = self.surrogate_fit
        budget = budget_status(self)
        correction = None if self.model_error is None else self.model_error.correction_pct
        return {
            "c1": float(self.theta[0]),
            "c5": float(self.theta[1]),
            "model_fit": {"c1": float(final.theta[0]), "c5": float(final.theta[1])},
            "correction": None
            if correction is None
            else {
                "c1_pct": float(correction[0]),
                "c5_pct": float(correction[1]),
                "reference": (self.model_error.budget_source or {}).get("rule"),
            },
            "c1_pct": float(self.bounds_pct[0]),
            "c5_pct": float(self.bounds_pct[1]),
            "bounds_include": model_error_scope(self.model_error, contact=self.contact),
            "statistical_pct": self.statistical_pct.tolist(),
            "friction": self._friction_dict(),
            "warnings": self.warnings,
            "adequacy": (
                self.adequacy.to_dict()
                | {
                    "tested_on": "the FE model one Gauss-Newton step from the fit (linearised)"
                    if self._confirmed
                    else "the fit"
                }
            )
            if self.adequacy is not None
            else {"note": self.adequacy_note},
            "error_budget": budget,
            "model_error": None if self.model_error is None else self.model_error.to_dict(),
            "F": final.F,
            "s": final.s,
            "n": final.n_residuals,
            "hessian": final.hessian.tolist(),
            "surrogate_fit": {"theta": first.theta.tolist(), "F": first.F, "wall_s": first.wall_s},
            "fe_fit": {"evaluations": final.evaluations, "wall_s": final.wall_s, "message": final.message}
            if self.refined
            else None,
            "fe_confirmation": None if self.confirmation is None else self.confirmation.to_dict(),
            "training_region": self.training_region,
            "fiber_angle_deg": inputs.dic.fiber_angle_deg,
            "fiber_angle_estimated": inputs.dic.fiber_angle_estimated,
            "registration": inputs.dic.to_dict(),
            "excluded_steps": list(inputs.objective.excluded_steps),
            "reading": inputs.objective.reading,
            "measured_nodes": int(inputs.objective.measured.sum()),
            "weights": inputs.eta.tolist(),
            "mesh_check": None if self.mesh_check is None else self.mesh_check.to_dict(self.check_mesh),
            "inputs": {
                **inputs.sources,
                "model": inputs.spec.to_dict(),
                "fe_stage_model": inputs.fe_stage_words(),
            },
        }

    def _friction_dict(self) -> dict:
        """fit.json's 'friction': the treatment and, with mu fitted, mu with its bound (eq. 6) and its
        95 % interval within the range (an end the certainty region reaches taken as the interval's:
        :func:`_mu_reach`), whether it ended on its range's limit, the bounds of (c1, c5) with mu
        known and mu's share. mu counts as identified only where its certainty region reaches
        neither end and its interval is not the whole range: bounded on one side only, or nowhere
        once the surrogate's own error is counted, the data fix no value of it."""
        out = {"treatment": self.friction.mode, "contact": self.contact}
        if self.friction.mode == "known":
            out["mu"] = self.friction.value
        fb = self.friction_bounds
        if fb is not None:
            mu, (lo, hi) = float(self.fit.theta[2]), self.mu_range
            mu_pct = float(np.hypot(fb["mu_pct"], self.mu_model_pct or 0.0))
            half = mu * mu_pct / 100.0
            laplace = [max(mu - half, lo), min(mu + half, hi)]  # nothing is known outside the range
            by_model = mu_reach_by_model_error(mu, self.mu_model_pct, (lo, hi))
            reach = {
                side: bool((self.mu_reach or {}).get(side) or by_model[side]) for side in ("lower", "upper")
            }
            interval = [lo if reach.get("lower") else laplace[0], hi if reach.get("upper") else laplace[1]]
            out |= {
                "mu": mu,
                "mu_pct": mu_pct,
                "mu_statistical_pct": fb["mu_pct"],
                "mu_model_pct": self.mu_model_pct,
                "mu_interval": interval,
                "mu_reaches_range_end": reach,
                "mu_reaches_range_end_by_model_error": by_model,
                "mu_reach_notes": self.mu_reach_notes,
                "restarts": self.restarts,
                "mu_identified": mu_is_identified(reach, mu_pct, interval, (lo, hi)),
                "mu_range": [lo, hi],
                "mu_at_limit": "lower" if mu <= lo * 1.001 else "upper" if mu >= hi * 0.999 else None,
                "conditional_pct": fb["conditional_pct"],
                "mu_share_pct": fb["mu_share_pct"],
            }
        return out

    def save(self, folder: str | Path) -> Path:
        """Write ``folder/fit.json`` atomically.

        Parameters
        ----------
        folder : str or pathlib.Path
            The folder.

        Returns
        -------
        pathlib.Path
            The file written.
        """
        return atomic_write_json(Path(folder) / "fit.json", self.to_dict())


def mu_is_identified(reach: dict, mu_pct: float, interval, mu_range) -> bool:
    """Whether a fit identifies mu (fit.json's ``friction.mu_identified``).

    Its certainty region reaches neither end of mu's range (``reach``: the statistical profile's
    answer merged with :func:`mu_reach_by_model_error`, the model's own errors on mu, so that a mu
    the model's error could move to the range's end is not claimed: issue 57, mu = 0.69 claimed on
    data made with the stick), its half-width is finite and its 95 % interval is not the whole range.

    Parameters
    ----------
    reach : dict
        ``{"lower": bool, "upper": bool}``: whether mu's certainty region reaches each end.
    mu_pct : float
        mu's 95 % half-width, percent (eq. 6, with the surrogate's part).
    interval : sequence of float
        mu's 95 % interval, within the range.
    mu_range : sequence of float
        The range (prior) of mu.

    Returns
    -------
    bool
    """
    return bool(
        not (reach.get("lower") or reach.get("upper"))
        and np.isfinite(mu_pct)
        and not interval_is_whole_range(interval, mu_range)
    )


def mu_reach_by_model_error(mu: float, model_pct: float | None, mu_range) -> dict[str, bool]:
    """Whether the model's own errors on mu (a 95 % half-width, percent) can move it to its range's ends.

    Read in log mu (mu is a scale): the lower end is reached when mu / (1 + m / 100) <= lo, the
    upper when mu (1 + m / 100) >= hi. The statistical profile (``_mu_reach``) does not see these
    errors, so a fit reports an end reached when either says so.

    Parameters
    ----------
    mu : float
        The fitted mu.
    model_pct : float or None
        :func:`mu_model_error_pct`; None: nothing known, nothing reached.
    mu_range : sequence of float
        mu's range (lo, hi).

    Returns
    -------
    dict
        ``{"lower": bool, "upper": bool}``.

    Examples
    --------
    >>> from indentation_studio.inference.experiment_fit import mu_reach_by_model_error
    >>> mu_reach_by_model_error(1.59, 1107.0, (0.1, 3.0))
    {'lower': True, 'upper': True}
    >>> mu_reach_by_model_error(0.5, 20.0, (0.1, 3.0))
    {'lower': False, 'upper': False}
    """
    lo, hi = (float(v) for v in mu_range)
    if model_pct is None or not np.isfinite(model_pct):
        return {"lower": model_pct is not None, "upper": model_pct is not None}
    factor = 1.0 + float(model_pct) / 100.0
    return {"lower": bool(mu / factor <= lo), "upper": bool(mu * factor >= hi)}


def interval_is_whole_range(interval, mu_range) -> bool:
    """Whether mu's 95 % interval is its whole range: the data bound it nowhere.

    Parameters
    ----------
    interval : sequence of float
        mu's 95 % interval, within the range.
    mu_range : sequence of float
        The range (prior) of mu.

    Returns
    -------
    bool
    """
    return bool(interval[0] <= mu_range[0] and interval[1] >= mu_range[1])


@threadpool_limits.wrap(limits=1, user_api="blas")  # OpenBLAS spins: see forward.threads
def fit_experiment(
    experiment: str | Path | ExperimentData,
    surrogate: str | Path | FieldSurrogate | None = None,
    *,
    weights=PAPER_WEIGHTS,
    refine: bool = True,
    paper_stop: bool = False,
    check_mesh: str | None = None,
    exclude_steps=(),
    say: Callable[[str], None] | None = None,
    friction: FrictionTreatment | str | float | None = None,
    force_noise: float | None = None,
    dic_noise: float | None = None,
    fe_stage: str = "auto",
    reading: str = "fit",
    registration_mm: float = REGISTRATION_MM,
) -> ExperimentFit:
    """Fit (c1, c5) to a measured experiment: on the surrogate, then on its FE model (paper 2.8.2).

    LM from {6, 300} kPa on the surrogate, then the FE stage on the FE model the surrogate was
    trained on (``fe_stage``, :data:`FE_STAGES`): one confirming run with the Gauss-Newton step it
    points to, or LM with its exact sensitivities; eq. 6 to 8 bounds with s from the data. On a
    surrogate trained with mu as a parameter (a campaign with a mu axis) the surrogate stage fits
    or holds mu too, and by default the FE model confirms the fit (seconds); on one without, that
    stage fits (c1, c5) with its contact as a start, and the FE fit (needed then) brings mu in. Every fit is tested for model adequacy
    (:mod:`inference.adequacy`: its residuals against the data's noise) and says whether its test
    has an error budget (:mod:`inference.budgets.check`).

    Parameters
    ----------
    experiment : str, pathlib.Path or ExperimentData
        The experiment (folder or loaded).
    surrogate : str, pathlib.Path, FieldSurrogate or None
        The surrogate (file or loaded); None (default): the one shipped for the experiment's test
        (:func:`~indentation_studio.inference.fit.inputs.prepare_fit`), said in ``say``.
    weights : array_like, default PAPER_WEIGHTS
        The weights of eq. 5.
    refine : bool, default True
        Run the FE stage at all (False: ``fe_stage="none"``).
    paper_stop : bool, default False
        Stop as soon as F < 3e-2 (the paper's rule).
    check_mesh : str, optional
        A finer mesh preset: adds the mesh check at the fit (the fit carried to that mesh with
        bounds that hold its discretisation uncertainty).
    exclude_steps : sequence of int, default ()
        Steps (1..N) left out of the fit beside those the experiment excludes; the result lists
        them all.
    say : callable, optional
        Where progress messages go.
    friction : FrictionTreatment, str or float, optional
        How the fit treats the indenter's friction coefficient mu: a value, ``identify``,
        ``marginalise[:LO:HI]``, ``assumed``; default (None) as :func:`default_friction` says.
    force_noise : float, optional
        Declared force noise (relative, per reading) for the adequacy test; default measured.
    dic_noise : float, optional
        Declared DIC noise (mm) for the adequacy test; default measured.
    fe_stage : {"auto", "confirm", "fit", "none"}, default "auto"
        What follows the surrogate's fit (:data:`FE_STAGES`).
    reading : str, default "fit"
        The objective (eq. 4's reading): the fit's, without the DIC rings from R to 1.5 R
        (docs/explanation/model-error.md), or ``paper``.
    registration_mm : float, default REGISTRATION_MM
        How far the indentation point found from the indenter's tracked points may lie from the
        true one, mm: the bounds carry its effect and that of the DIC-points-to-nodes planes,
        measured at the fit (``inference.experiment.processing_error``).

    Returns
    -------
    ExperimentFit
        Both stages, the bounds and the checks.

    Raises
    ------
    ValueError
        If ``fe_stage`` is none of :data:`FE_STAGES`, or the friction treatment needs an FE fit
        that is not asked for.

    Examples
    --------
    >>> import indentation_studio as ins
    >>> fit = ins.fit_experiment("runs/experiments/synthetic", "surrogate-gp.safetensors")  # doctest: +SKIP
    >>> fit.fit.theta, fit.fit.bounds_pct  # doctest: +SKIP
    """
    say = say or (lambda message: None)
    inputs = prepare_fit(experiment, surrogate, weights, exclude_steps, reading=reading)
    if surrogate is None:
        say(f"surrogate: {inputs.sources['surrogate']}")
    stage = resolved_fe_stage(fe_stage, inputs.surrogate, refine=refine)
    treatment = (
        default_friction(inputs.surrogate, stage == "fit" and check_mesh is None)
        if friction is None
        else FrictionTreatment.parse(friction)
    )
    f_stop = PAPER_F_STOP if paper_stop else None
    if treatment.mode != "assumed" or "mu" in inputs.surrogate.parameters:
        result = _fit_with_friction(inputs, treatment, stage, f_stop, check_mesh, say, registration_mm)
        result.adequacy, result.adequacy_note = fit_adequacy(
            result, force_noise=force_noise, dic_noise=dic_noise, registration_mm=registration_mm
        )
        return result
    say(f"fitting on the {inputs.surrogate.kind} surrogate ...")
    first = fit_parameters(inputs.objective, inputs.surrogate, inputs.eta, f_stop=f_stop)
    final = first
    two_level = has_high_fidelity_level(inputs.surrogate)
    if stage == "fit":
        fe = inputs.fe_model()
        if (
            two_level and not paper_stop
        ):  # the surrogate already emulates this FE model: confirm by Gauss-Newton
            say(
                f"refining by Gauss-Newton on {inputs.fe_stage_words()} from {first.theta.round(3).tolist()} kPa ..."
            )
            final = gauss_newton_refine(inputs.objective, fe, inputs.eta, first.theta)
        else:
            say(f"refining on the FE solver from {first.theta.round(3).tolist()} kPa ...")
            final = fit_parameters(
                inputs.objective, fe, inputs.eta, theta0=first.theta, f_stop=f_stop, progress=_told(say)
            )
    check = None
    if check_mesh is not None:
        check, _ = check_mesh_at(inputs.spec, inputs.objective, inputs.eta, final.theta, check_mesh, say)
    if two_level:
        say("the model error at the fit (discrepancy and error budget) ...")
    model_error = model_error_at(
        inputs.objective, inputs.eta, inputs.surrogate, final.theta, on_surrogate=stage != "fit"
    )
    model_error = _with_processing(
        model_error, inputs, final.theta, inputs.spec.contact.describe(), registration_mm, say
    )
    result = ExperimentFit(inputs, first, final, stage == "fit", check, check_mesh, model_error)
    if stage == "confirm":
        say(f"confirming on the FE solver at {first.theta.round(3).tolist()} kPa ...")
        result.confirmation = _confirm(result, inputs.fe_model(), None)
    result.adequacy, result.adequacy_note = fit_adequacy(
        result, force_noise=force_noise, dic_noise=dic_noise, registration_mm=registration_mm
    )
    return result


def resolved_fe_stage(fe_stage: str, surrogate, *, refine: bool = True) -> str:
    """The FE stage a fit runs (:data:`FE_STAGES`): ``auto`` made ``confirm`` on a surrogate trained
    with mu, ``fit`` on one without; ``none`` whenever ``refine`` is False.

    Parameters
    ----------
    fe_stage : str
        One of :data:`FE_STAGES`.
    surrogate : FieldSurrogate
        The surrogate the fit starts on.
    refine : bool, default True
        False: no FE stage at all.

    Returns
    -------
    str
        ``confirm``, ``fit`` or ``none``.

    Raises
    ------
    ValueError
        If ``fe_stage`` is none of :data:`FE_STAGES`.
    """
    if fe_stage not in FE_STAGES:
        raise ValueError(f"fe_stage {fe_stage!r}: use one of {', '.join(FE_STAGES)}")
    if not refine:
        return "none"
    if fe_stage == "auto":
        return "confirm" if "mu" in surrogate.parameters else "fit"
    return fe_stage


def _confirm(fit: ExperimentFit, fe, box) -> FitConfirmation:
    """The FE confirmation of a fit that ended on the surrogate (:func:`confirm_fit`); with mu fitted,
    mu's own bound (eq. 6) beside those of (c1, c5)."""
    inputs = fit.inputs
    bounds = fit.statistical_pct
    fb = fit.friction_bounds
    if fb is not None and fit.fit.theta.size == 3:
        bounds = np.append(bounds, fb["mu_pct"] if np.isfinite(fb["mu_pct"]) else np.inf)
    return confirm_fit(
        inputs.objective,
        fe,
        inputs.eta,
        fit.fit.theta,
        F_surrogate=fit.fit.F,
        statistical_pct=bounds,
        box=box,
    )


def default_friction(surrogate, fe_stage: bool = True) -> FrictionTreatment:
    """How a fit treats mu when not told.

    On a surrogate trained with mu: marginalised (a log-uniform prior over its mu range; it has
    no contact to assume). On one without: marginalised
    over 0.1 .. 3 when the FE stage can bring mu in (``fe_stage``: the FE refinement and no mesh
    check, which is made with the stick) and the surrogate is single-level (a multi-fidelity
    surrogate's FE stage is the high-fidelity mesh's Gauss-Newton check, with its own model
    error); else the surrogate's contact assumed, the fit warning what that costs.
    Why (README, "Friction"): on synthetic data made with mu = 0.3, 1, 3 and the perfect stick
    (two truths), a perfect-stick fit put c5 28 to 34 % low at mu = 0.3, the truth outside its
    bounds, while the marginalised fit held the truth in every case; where nothing slips it gives
    the stick's (c1, c5) and bounds, mu's interval then reaching the range's upper end.

    Parameters
    ----------
    surrogate : FieldSurrogate
        The surrogate the fit starts on.
    fe_stage : bool, default True
        Whether the FE stage can bring mu in (the FE refinement and no mesh check).

    Returns
    -------
    FrictionTreatment
        ``marginalise`` (no range of its own: the fit takes the surrogate's mu range, else
        0.1 .. 3) or ``assumed``.
    """
    if "mu" in surrogate.parameters or (fe_stage and not has_high_fidelity_level(surrogate)):
        return FrictionTreatment("marginalise")
    return FrictionTreatment()


def _mu_range(treatment: FrictionTreatment, surrogate, fe_stage: bool = False) -> tuple[float, float] | None:
    """The range mu is kept in (identify) or the prior's (marginalise): the treatment's, else the
    surrogate's training range when mu is one of its parameters, else DEFAULT_MU_RANGE. A range
    or a known mu outside the surrogate's training range is refused (the surrogate would
    extrapolate) unless an FE stage follows (``fe_stage``: the surrogate stage then keeps to its
    own range and the FE stage takes the one asked for)."""
    if "mu" not in surrogate.parameters:
        return (treatment.mu_range or DEFAULT_MU_RANGE) if treatment.fits_mu else None
    j = surrogate.parameters.index("mu")
    lo, hi = float(surrogate.scaler.lo[j]), float(surrogate.scaler.hi[j])
    wanted = treatment.mu_range or (lo, hi)
    if treatment.mode == "known":
        wanted = (treatment.value, treatment.value)
    if not fe_stage and (wanted[0] < lo * (1 - 1e-9) or wanted[1] > hi * (1 + 1e-9)):
        raise ValueError(
            f"friction: mu {wanted[0]:g}..{wanted[1]:g} lies outside the range the surrogate was trained "
            f"on ({lo:g}..{hi:g}); fit with the FE stage on a surrogate without mu, or train one wider"
        )
    return wanted if treatment.fits_mu else None


def check_parameter_order(model) -> None:
    """A surrogate with mu must take theta as (c1, c5, mu): the fits, the bounds and the posterior
    read mu as the third parameter. Campaign grids are put in that order whatever the order
    written (:func:`campaign.designs.parse_grid`); a surrogate of another order is refused here."""
    names = tuple(model.parameters)
    if "mu" in names and names != ("c1", "c5", "mu"):
        raise ValueError(
            f"friction: this surrogate's parameters are {names}; a fit with mu needs them as "
            "('c1', 'c5', 'mu'): train it again on a campaign whose grid gives c1, c5, mu"
        )


def surrogate_with_mu(
    model, treatment: FrictionTreatment, mu_range: tuple[float, float] | None
) -> tuple[object, tuple[np.ndarray, np.ndarray]]:
    """The Predictor a fit or a posterior on a surrogate trained with mu (its third parameter) works
    on, and the box theta stays in: mu held (``known``: a FixedParameter over (c1, c5), mu at the
    training range's nearest end if outside it) or fitted within ``mu_range`` (identify,
    marginalise), inside the box the surrogate was trained on (outside it a GP falls back to its
    mean)."""
    check_parameter_order(model)
    inside = (np.array(model.scaler.lo, float), np.array(model.scaler.hi, float))  # copies
    lo, hi = inside[0][2], inside[1][2]
    if treatment.mode == "known":
        held = FixedParameter(model, "mu", float(np.clip(treatment.value, lo, hi)))
        return held, (inside[0][:2], inside[1][:2])
    if not treatment.fits_mu:
        raise ValueError(f"friction {treatment.mode}: a surrogate with mu needs mu held or fitted")
    inside[0][2], inside[1][2] = np.clip(mu_range[0], lo, hi), np.clip(mu_range[1], lo, hi)
    if inside[1][2] <= inside[0][2]:
        raise ValueError(f"friction: mu's range {mu_range} misses the surrogate's ({lo:g}..{hi:g})")
    return model, inside


def fit_on_surrogate_with_mu(
    objective,
    model,
    eta,
    treatment: FrictionTreatment,
    mu_range: tuple[float, float] | None,
    f_stop: float | None = None,
) -> FitResult:
    """The surrogate stage of a fit on a surrogate trained with mu (:func:`surrogate_with_mu`):
    with mu fitted, from the paper's start at three mu spread in log over the range (where nothing
    slips d/dmu = 0 holds a single start still), the best kept."""
    predictor, box = surrogate_with_mu(model, treatment, mu_range)
    if treatment.mode == "known":
        return fit_parameters(objective, predictor, eta, f_stop=f_stop, box=box)
    starts = np.geomspace(box[0][2], box[1][2], 3)
    fits = [fit_parameters(objective, model, eta, (*PAPER_START, m), f_stop, box=box) for m in starts]
    return min(fits, key=lambda fit: fit.F)


def _fit_with_friction(
    inputs: FitInputs,
    treatment: FrictionTreatment,
    stage: str,
    f_stop: float | None,
    check_mesh: str | None,
    say: Callable[[str], None],
    registration_mm: float = REGISTRATION_MM,
) -> ExperimentFit:
    """fit_experiment with mu known, identified or marginalised (or a surrogate with mu)."""
    model, spec = inputs.surrogate, inputs.spec
    with_mu = "mu" in model.parameters
    if with_mu and treatment.mode == "assumed":
        raise ValueError(
            "friction: this surrogate was trained with mu as a parameter; say how the fit treats it "
            "(a value, 'identify' or 'marginalise')"
        )
    if with_mu:
        check_parameter_order(model)
    if check_mesh is not None:
        raise ValueError("friction: the mesh check is made with the perfect stick; fit without --check-mesh")
    refine = stage == "fit"
    mu_range = _mu_range(treatment, model, fe_stage=refine)
    if not with_mu and not refine and treatment.fits_mu:
        raise ValueError(
            f"friction {treatment.mode}: the surrogate has no mu, so only the FE stage can bring it in; "
            "fit with the FE refinement (--fe-stage fit)"
        )
    if not with_mu and not refine:  # mu known: the surrogate's contact is not that mu's
        raise ValueError(
            f"friction {treatment.mode}: the surrogate has no mu, so only the FE fit can hold it at "
            f"{treatment.value:g}; fit with --fe-stage fit"
        )
    obj, eta = inputs.objective, inputs.eta
    say(
        f"fitting on the {model.kind} surrogate ({treatment.describe(spec.contact.describe(), mu_range)}) ..."
    )
    if with_mu:
        first = fit_on_surrogate_with_mu(obj, model, eta, treatment, mu_range, f_stop)
        inside = surrogate_with_mu(model, treatment, mu_range)[1]
    else:  # (c1, c5) with the surrogate's contact: the FE stage's start
        first = fit_parameters(obj, model, eta, f_stop=f_stop)
        inside = None
    final = first
    fitted_on, fit_box = model, inside
    edge = [model.parameters[j] for j, _ in training_box_ends(model, first.theta) if j < 2]
    if stage == "confirm" and with_mu and edge:
        # the surrogate cannot give a value outside its box, and a Gauss-Newton step from its edge
        # is held there: the FE model, which can, fits instead
        say(
            f"the surrogate's fit sits at the edge of its training box in {', '.join(edge)}: the data may "
            "want a value outside it; fitting on the FE model instead (LM with exact sensitivities) ..."
        )
        stage, refine = "fit", True
    if refine:
        box = None
        if treatment.mode == "known":
            fe = inputs.fe_model(friction=treatment.value)
            start = first.theta
        else:
            fe = inputs.fe_model(with_mu=True)
            box = (np.array([0.0, 0.0, mu_range[0]]), np.array([np.inf, np.inf, mu_range[1]]))
            start = first.theta if with_mu else _fe_start(obj, fe, eta, first.theta, mu_range, say)
        say(f"refining on the FE solver from {np.round(start, 3).tolist()} ...")
        final = fit_parameters(obj, fe, eta, theta0=start, f_stop=f_stop, box=box, progress=_told(say))
        fitted_on, inside, fit_box = fe, None, box
    reach, notes, restarts = None, {}, []
    if treatment.fits_mu:
        say("checking mu's certainty region up to its range's ends (c1, c5 fitted again there) ...")
        reach, notes, better = _mu_reach(obj, fitted_on, eta, final, mu_range, inside)
        # a point at a range end with F below the fit's certainty region: the fit is a local
        # minimum (a poor surrogate stage can start the FE stage in another basin), so fit again
        while better is not None and len(restarts) < MAX_RESTARTS:
            theta_b, F_b = better
            say(
                f"F = {F_b:.4g} at {np.round(theta_b, 3).tolist()} lies below the fit's F = {final.F:.4g}: "
                "the fit was a local minimum; fitting again from there ..."
            )
            again = fit_parameters(
                obj,
                fitted_on,
                eta,
                theta0=theta_b,
                f_stop=f_stop,
                box=fit_box,
                progress=_told(say) if refine else None,
            )
            restarts.append(
                {"from": theta_b.tolist(), "F_there": F_b, "F_before": final.F, "F_after": again.F}
            )
            if again.F >= final.F:
                break
            final = again
            reach, notes, better = _mu_reach(obj, fitted_on, eta, final, mu_range, inside)
    fit = ExperimentFit(
        inputs,
        first,
        fit=final,
        refined=refine,
        mesh_check=None,
        check_mesh=None,
        model_error=None,
        friction=treatment,
        mu_range=mu_range,
    )
    if with_mu:
        fit.model_error = model_error_with_mu(
            inputs,
            treatment,
            mu_range,
            final.theta,
            on_surrogate=not refine,
            registration_mm=registration_mm,
            say=say,
        )
    else:  # the stick surrogate's field at (c1, c5) stands for the model's
        error = _stick_mesh_budget(model, fit.contact, spec.contact.describe(), theta=final.theta)
        fit.model_error = _with_processing(error, inputs, final.theta[:2], fit.contact, registration_mm, say)
    fit.mu_reach, fit.mu_reach_notes, fit.restarts = reach, notes, restarts
    if with_mu and treatment.fits_mu:
        fit.mu_model_pct = mu_model_error_pct(inputs, final.theta, on_surrogate=not refine)
    if stage == "confirm":
        say(f"confirming on the FE solver at {np.round(final.theta, 3).tolist()} ...")
        if treatment.mode == "known":
            fe = inputs.fe_model(friction=treatment.value)
        else:
            fe = inputs.fe_model(with_mu=True)
        fit.confirmation = _confirm(fit, fe, inside if treatment.fits_mu else None)
    return fit


def model_error_with_mu(
    inputs: FitInputs,
    treatment: FrictionTreatment,
    mu_range: tuple[float, float] | None,
    theta: np.ndarray,
    *,
    on_surrogate: bool,
    registration_mm: float = REGISTRATION_MM,
    say: Callable[[str], None] | None = None,
) -> ModelError | None:
    """The model-error parts of (c1, c5) at a fit on a surrogate trained with mu, mu held there.

    The discrepancy's uncertainty and the error budget of a multi-fidelity surrogate
    (:func:`~indentation_studio.inference.budgets.model_error.model_error_at`, mu held: at mu's range ends
    nothing slips and d/dmu vanishes), or the stick-measured budget of a single-level one
    (:func:`_stick_mesh_budget`); the surrogate's own error where the final stage is on it; the
    processing's part. A fit and a posterior of the same data carry the same parts.

    Parameters
    ----------
    inputs : FitInputs
        The experiment, surrogate (with mu) and objective.
    treatment : FrictionTreatment
        How mu is treated.
    mu_range : tuple of float or None
        mu's range (identify, marginalise).
    theta : numpy.ndarray
        The fit: (c1, c5, mu), or (c1, c5) with mu known.
    on_surrogate : bool
        The final stage is on the surrogate (its own error counted).
    registration_mm : float, default REGISTRATION_MM
        The indentation point's uncertainty, mm.
    say : callable, optional
        Where progress messages go.

    Returns
    -------
    ModelError or None
        The parts over (c1, c5); None where nothing is known.
    """
    say = say or (lambda message: None)
    model, obj, eta = inputs.surrogate, inputs.objective, inputs.eta
    contact = treatment.describe(inputs.spec.contact.describe(), mu_range)
    at = _with_held_mu(theta, model, treatment)
    if has_high_fidelity_level(model):  # its discrepancy (learned at the stick or over mu)
        say("the model error at the fit (discrepancy and error budget, mu held) ...")
        error = model_error_at(obj, eta, model, at, free=2, on_surrogate=on_surrogate)
    else:
        error = _stick_mesh_budget(model, contact, inputs.spec.contact.describe(), theta=theta)
        if on_surrogate:  # the final stage on the surrogate: its own error too
            error = with_emulation_error(error, obj, eta, model, at, free=2)
    error = None if error is None else replace(error, contact=contact)
    return _with_processing(error, inputs, at, contact, registration_mm, say, free=2)


def mu_model_error_pct(inputs: FitInputs, theta: np.ndarray, *, on_surrogate: bool) -> float | None:
    """What the model's own errors leave on a fitted mu: a 95 % half-width, percent of mu.

    Every parameter free (mu's certainty is what is asked): the surrogate's held-out errors pushed
    through the fit where its final stage is on it
    (:func:`~indentation_studio.inference.budgets.model_error.emulation_error_pct`), and, on a
    multi-fidelity surrogate with mu inside its range, the discrepancy's uncertainty pushed the same
    way (:func:`~indentation_studio.inference.budgets.model_error.model_error_at` over all three), root sum of
    squares. A model error that moves mu by its whole range is what makes data with no slip in them
    look as if they held a mu.

    Parameters
    ----------
    inputs : FitInputs
        The experiment, surrogate (with mu) and objective.
    theta : numpy.ndarray
        (c1, c5, mu) the fit.
    on_surrogate : bool
        The final stage is on the surrogate.

    Returns
    -------
    float or None
        The half-width; None where neither part is known.
    """
    model, obj, eta = inputs.surrogate, inputs.objective, inputs.eta
    parts = []
    if on_surrogate:
        moved = emulation_error_pct(obj, eta, model, theta)
        if moved is not None:
            parts.append(float(moved[2]))
    lo, hi = (float(model.scaler.lo[2]), float(model.scaler.hi[2]))
    if has_high_fidelity_level(model) and lo * 1.01 < theta[2] < hi / 1.01:
        try:
            error = model_error_at(obj, eta, model, theta, on_surrogate=False)
        except np.linalg.LinAlgError:  # mu not determined there: nothing to push through
            error = None
        if error is not None and np.isfinite(error.discrepancy_pct[2]):
            parts.append(float(error.discrepancy_pct[2]))
    return float(np.hypot.reduce(parts)) if parts else None


#: Starts in mu of the FE stage of a fit with mu on a surrogate without it (spread in log over mu's range).
FE_MU_STARTS = 3


def _fe_start(objective, fe, eta, theta: np.ndarray, mu_range: tuple[float, float], say) -> np.ndarray:
    """Where the FE stage of a fit with mu starts when the surrogate has no mu: (c1, c5) of the
    surrogate stage with the mu of ``FE_MU_STARTS`` spread in log over the range whose F is lowest
    (one run each, no sensitivities). The objective is flat in mu where nothing slips and not
    smooth where nodes switch between stick and slip, so a single start in the middle of the range
    can hold the fit in a valley far above the data's minimum (FEBio's baseline: from mu = 0.55 the
    fit stopped at F = 0.043 near mu = 0.5, where mu = 3 gives 0.030)."""
    best, best_F, skipped = None, np.inf, []
    for mu in np.geomspace(mu_range[0], mu_range[1], FE_MU_STARTS):
        point = np.append(theta, mu)
        try:
            F = float(objective.value(fe.predict(point[None, :]), eta)[0])
        except SimulationError as exc:  # a start, not the fit: skipped and counted, no alarm
            skipped.append(f"mu = {mu:.3g} (stops at {exc.depth_reached:g} mm)")
            continue
        say(f"  start at mu = {mu:.3g}: F = {F:.4g}")
        if F < best_F:
            best, best_F = point, F
    if skipped:
        say(
            f"  {len(skipped)} of {FE_MU_STARTS} starts skipped, not simulable at this (c1, c5): {', '.join(skipped)}"
        )
    if best is None:
        raise SimulationError(f"no start of the FE stage in mu's range {mu_range} could be simulated", 0.0)
    return best


#: A surrogate stage whose F ends more than this many times the FE fit's (the same model) misses the data.
SURROGATE_MISS_RATIO = 3.0

#: How often a fit with mu starts again from a better point its range-end check found.
MAX_RESTARTS = 2


def _mu_reach(
    objective,
    predictor,
    eta,
    fit: FitResult,
    mu_range: tuple[float, float],
    box: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[dict[str, bool], dict[str, str], tuple[np.ndarray, float] | None]:
    """Whether eq. 6's certainty region of the fit, F(theta) - F(theta_hat) <= s^2, reaches each end
    of mu's range: the profile of F at the end, (c1, c5) fitted again with mu held there (on a
    surrogate a fit within ``box``; on the FE model, where a run takes minutes, one Gauss-Newton
    step from the fit's (c1, c5): the linearised least squares ||r - J (J^T J)^-1 J^T r||^2 of the
    (c1, c5) columns, one run with sensitivities). Holding (c1, c5) at the fit instead would
    overstate F there, as (c1, c5) move with mu, and call mu bounded where it is not. A fit on an
    end counts as reaching it; an end whose simulation fails counts as reached (nothing known there),
    the reason in the notes. Where nothing slips the data say nothing of mu and F is flat above
    some mu: the Hessian's bound of mu (local) would then be a confident wrong answer.

    Also returns a better point, (theta, F), where one was found with F below F(theta_hat) - s^2
    (on the FE model the Gauss-Newton step's point, run once more when its linearised F is that
    low): then the fit is not the minimum (None otherwise)."""
    reach, notes, better = {}, {}, None
    for side, end in zip(("lower", "upper"), mu_range, strict=True):
        if abs(np.log(fit.theta[2] / end)) < 1e-3:
            reach[side], notes[side] = True, "the fit ends on it"
            continue
        try:
            F_end, theta_end, F_there = _profile_at(
                objective, predictor, eta, fit.theta[:2], end, box, fit.F - fit.s**2
            )
        except SimulationError as exc:
            reach[side] = True
            notes[side] = f"taken as reached: the simulation at mu = {end:g} failed ({exc})"
            continue
        reach[side] = bool(F_end - fit.F <= fit.s**2)
        if F_there is not None and F_there < fit.F - fit.s**2 and (better is None or F_there < better[1]):
            better = (theta_end, F_there)
    return reach, notes, better


def _profile_at(
    objective, predictor, eta, c1_c5: np.ndarray, mu: float, box, below: float
) -> tuple[float, np.ndarray, float | None]:
    """min over (c1, c5) of F(c1, c5, mu): a fit of (c1, c5) with mu held (cheap predictors), or on
    the FE model one Gauss-Newton step's linearised value from ``c1_c5``. Returns that value, the
    point (c1, c5, mu) it is at, and F there as evaluated (on the FE model only when the
    linearised value is ``below``, one run more; else None)."""
    if isinstance(predictor, FESolverPredictor) or isinstance(
        getattr(predictor, "low", None), FESolverPredictor
    ):
        theta = np.array([c1_c5[0], c1_c5[1], mu])
        r, J = residuals_at(objective, predictor, eta, theta)
        step, *_ = np.linalg.lstsq(J[:, :2], -r, rcond=None)
        left = r + J[:, :2] @ step
        stepped = theta * np.exp(np.append(step, 0.0))
        F_there = None
        if float(left @ left) < below:
            try:
                F_there = float(objective.value(predictor.predict(stepped[None, :]), eta)[0])
            except SimulationError:
                F_there = None
        return float(left @ left), stepped, F_there
    held = FixedParameter(predictor, "mu", mu)
    two = None if box is None else (box[0][:2], box[1][:2])
    start = c1_c5 if two is None else np.clip(c1_c5, two[0], two[1])
    profile = fit_parameters(objective, held, eta, theta0=start, box=two)
    return profile.F, np.append(profile.theta, mu), profile.F


def _with_processing(
    model_error: ModelError | None,
    inputs: FitInputs,
    theta: np.ndarray,
    contact: str,
    registration_mm: float,
    say: Callable[[str], None],
    *,
    free: int | None = None,
) -> ModelError:
    """The fit's model error with the experiment's processing part measured at ``theta`` on the
    fit's surrogate (``inference.experiment.processing_error``)."""
    say(
        f"the processing's part at the fit (DIC points to nodes, registration within {registration_mm:g} mm) ..."
    )
    processing = processing_error_at(
        inputs.objective,
        inputs.dic,
        inputs.surrogate,
        theta,
        inputs.eta,
        used_steps=inputs.experiment.used_steps,
        registration_mm=registration_mm,
        free=free,
    )
    return with_processing_error(model_error, processing, contact)


def _with_held_mu(theta: np.ndarray, model, treatment: FrictionTreatment) -> np.ndarray:
    """(c1, c5, mu) of a fit on a surrogate with mu: mu as fitted, or the value held (at the
    training range's nearest end, as :func:`surrogate_with_mu` holds it)."""
    theta = np.asarray(theta, float)
    if theta.size == len(model.parameters):
        return theta
    return np.append(theta, np.clip(treatment.value, model.scaler.lo[2], model.scaler.hi[2]))


def _stick_mesh_budget(surrogate, contact: str, measured_with: str, *, theta) -> ModelError | None:
    """The mesh's error budget of the surrogate's (c1, c5), measured with the perfect stick, for a
    fit with friction: that mesh's error does not vanish when mu is held or fitted, and no budget
    measured with friction is shipped; leaving it out would leave bounds of noise alone (a fit of
    FEBio's baseline with mu identified: c5 +34 % outside +-3.9 %). Its source says which contact
    it was measured with (``measured_with``: the surrogate's campaign's contact, which the shipped
    budget was matched on), read at the fit ``theta`` (``surrogate.error_budgets.budget_at``)."""

    budget = budget_at(surrogate_error_budget(surrogate), theta)
    if not budget:
        return None
    source = dict(budget.get("source") or {}) | {"measured_with": measured_with}
    pct = np.array([float(budget.get("c1_pct", 0.0)), float(budget.get("c5_pct", 0.0))])
    correction = budget_correction(budget, ("c1", "c5"))
    return ModelError(np.zeros(2), pct, np.zeros((2, 2)), source, False, contact, correction_pct=correction)


def _told(say: Callable[[str], None]) -> Callable[[int, np.ndarray, float], None]:
    """An FE fit's evaluations, one line each, for ``say``."""
    return lambda k, theta, F: say(f"  FE evaluation {k}: {np.round(theta, 4).tolist()}, F = {F:.4g}")
