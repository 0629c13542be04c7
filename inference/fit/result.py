"""A fit of an experiment (:class:`ExperimentFit`): the surrogate stage, the final fit, its checks,
its bounds and fit.json."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ...atomic_write import atomic_write_json
from ...design.friction_treatment import FrictionTreatment, friction_bounds
from ...surrogate.base import SPARSE_GAP
from ..adequacy.of_fit import training_box_ends
from ..budgets.check import budget_status
from ..budgets.mesh_check import MeshCheck
from ..budgets.model_error import ModelError, combined_pct, model_error_scope
from .confirm_stage import FitConfirmation, confirm_fit
from .error_parts import left_out_with_friction
from .held_out_refits import HeldOutRefits
from .inputs import FitInputs
from .inverse_fit import FitResult
from .mu_reach import mu_is_identified, mu_reach_by_model_error

__all__ = ["SURROGATE_MISS_RATIO", "ExperimentFit"]


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
    # the fit made again with each of the discrepancy's held-out errors (fit.held_out_refits): an
    # end one of them reaches is one the model's own error reaches
    mu_refits: HeldOutRefits | None = None
    # why mu's model error at the high fidelity is not measured (fit.error_parts.mu_model_error_unmeasured):
    # then mu is not claimed, its interval the whole range
    mu_unmeasured: str | None = None
    adequacy: object | None = None  # inference.adequacy.chi_square.Adequacy: can the model explain the data
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
            (:func:`inference.adequacy.of_fit.training_box_ends`; mu's range end is named by fit.json's
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
            "bounds_include": model_error_scope(
                self.model_error,
                contact=self.contact,
                unmeasured=left_out_with_friction(self.inputs),
            ),
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
            if self.mu_refits is not None:
                refit_reach = self.mu_refits.reaches(2)
                by_model = {side: by_model[side] or refit_reach[side] for side in by_model}
            if self.mu_unmeasured is not None:
                by_model = {"lower": True, "upper": True}
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
                "mu_model_unmeasured": self.mu_unmeasured,
                "mu_held_out_refits": None if self.mu_refits is None else self.mu_refits.describe(2),
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


def _confirm(fit: ExperimentFit, fe, box) -> FitConfirmation:
    """The FE confirmation of a fit that ended on the surrogate (:func:`confirm_fit`); with mu fitted,
    mu's own bound (eq. 6) beside those of (c1, c5). The shift is held to the statistical bound
    and the surrogate's own error: (c1, c5)'s from the model error's surrogate part, mu's from its
    model error (infinite where mu is not claimed: its interval is then its whole range)."""
    inputs = fit.inputs
    bounds = fit.statistical_pct
    me = fit.model_error
    own = np.zeros(2) if me is None or me.surrogate_pct is None else np.asarray(me.surrogate_pct, float)[:2]
    fb = fit.friction_bounds
    if fb is not None and fit.fit.theta.size == 3:
        bounds = np.append(bounds, fb["mu_pct"] if np.isfinite(fb["mu_pct"]) else np.inf)
        mu_own = np.inf if fit.mu_unmeasured else (fit.mu_model_pct or 0.0)
        own = np.append(own, mu_own)
    return confirm_fit(
        inputs.objective,
        fe,
        inputs.eta,
        fit.fit.theta,
        F_surrogate=fit.fit.F,
        statistical_pct=bounds,
        box=box,
        surrogate_pct=own,
    )


#: A surrogate stage whose F ends more than this many times the FE fit's (the same model) misses the data.
SURROGATE_MISS_RATIO = 3.0
