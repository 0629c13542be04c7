"""The inverse fit of a measured experiment (paper 2.8.2): Levenberg-Marquardt on the surrogate,
then on the FE solver with its exact sensitivities, bounds from eq. 6 to 8; optionally the mesh check
at the fit (:mod:`inference.mesh_check`) and the fit carried to the finer mesh."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..atomic_write import atomic_write_json
from ..design.objective import PAPER_WEIGHTS
from ..forward.predictor import FESolverPredictor
from ..surrogate.base import FieldSurrogate
from .experiment_data import ExperimentData
from .fit_inputs import FitInputs, prepare_fit
from .inverse_fit import PAPER_F_STOP, FitResult, fit_parameters, gauss_newton_refine
from .mesh_check import MeshCheck, check_mesh_at
from .model_error import ModelError, combined_pct, has_high_fidelity_level, model_error_at, model_error_scope

__all__ = ["ExperimentFit", "fit_experiment"]


@dataclass
class ExperimentFit:
    """The surrogate stage, the final (FE-refined) fit, and the mesh check when asked for."""

    inputs: FitInputs
    surrogate_fit: FitResult
    fit: FitResult  # the FE fit when refined, else the surrogate fit
    refined: bool
    mesh_check: MeshCheck | None = None
    check_mesh: str | None = None  # the preset the mesh check solved on
    model_error: ModelError | None = None  # with a high-fidelity level: the model-error parts

    @property
    def bounds_pct(self) -> np.ndarray:
        """The reported 95 % half-width: statistical and, where known, model error combined."""
        return combined_pct(self.fit.bounds_pct, self.model_error)

    def to_dict(self) -> dict:
        """fit.json: theta, bounds (statistical only unless a mesh check is present), provenance."""
        final, inputs = self.fit, self.inputs
        first = self.surrogate_fit
        return {
            "c1": float(final.theta[0]),
            "c5": float(final.theta[1]),
            "c1_pct": float(self.bounds_pct[0]),
            "c5_pct": float(self.bounds_pct[1]),
            "bounds_include": model_error_scope(self.model_error, contact=inputs.spec.contact.describe()),
            "statistical_pct": final.bounds_pct.tolist(),
            "model_error": None if self.model_error is None else self.model_error.to_dict(),
            "F": final.F,
            "s": final.s,
            "n": final.n_residuals,
            "hessian": final.hessian.tolist(),
            "surrogate_fit": {"theta": first.theta.tolist(), "F": first.F, "wall_s": first.wall_s},
            "fe_fit": {"evaluations": final.evaluations, "wall_s": final.wall_s, "message": final.message}
            if self.refined
            else None,
            "fiber_angle_deg": inputs.dic.fiber_angle_deg,
            "fiber_angle_estimated": inputs.dic.fiber_angle_estimated,
            "registration": inputs.dic.to_dict(),
            "excluded_steps": list(inputs.objective.excluded_steps),
            "measured_nodes": int(inputs.objective.measured.sum()),
            "weights": inputs.eta.tolist(),
            "mesh_check": None if self.mesh_check is None else self.mesh_check.to_dict(self.check_mesh),
            "inputs": {**inputs.sources, "model": inputs.spec.to_dict()},
        }

    def save(self, folder: str | Path) -> Path:
        """Write ``folder/fit.json`` atomically and return its path."""
        return atomic_write_json(Path(folder) / "fit.json", self.to_dict())


def fit_experiment(
    experiment: str | Path | ExperimentData,
    surrogate: str | Path | FieldSurrogate,
    weights=PAPER_WEIGHTS,
    refine: bool = True,
    paper_stop: bool = False,
    check_mesh: str | None = None,
    exclude_steps=(),
    say: Callable[[str], None] | None = None,
) -> ExperimentFit:
    """Fit (c1, c5) to a measured experiment: LM from {6, 300} kPa on the surrogate, then (``refine``)
    on the FE model the surrogate was trained on, with its exact sensitivities; eq. 6 to 8 bounds
    with s from the data. ``paper_stop`` stops as soon as F < 3e-2 (the paper's rule).
    ``check_mesh`` (a finer mesh preset) adds the mesh check at the fit: the fit carried to that
    mesh with bounds that hold its discretisation uncertainty. ``exclude_steps`` (1..N) are left
    out of the fit beside those the experiment excludes; the result lists them all."""
    say = say or (lambda message: None)
    inputs = prepare_fit(experiment, surrogate, weights, exclude_steps)
    f_stop = PAPER_F_STOP if paper_stop else None
    say(f"fitting on the {inputs.surrogate.kind} surrogate ...")
    first = fit_parameters(inputs.objective, inputs.surrogate, inputs.eta, f_stop=f_stop)
    final = first
    two_level = has_high_fidelity_level(inputs.surrogate)
    if refine:
        fe = FESolverPredictor(inputs.spec)
        if (
            two_level and not paper_stop
        ):  # the surrogate already emulates this FE model: confirm by Gauss-Newton
            say(
                f"refining by Gauss-Newton on the high-fidelity FE model from {first.theta.round(3).tolist()} kPa ..."
            )
            final = gauss_newton_refine(inputs.objective, fe, inputs.eta, first.theta)
        else:
            say(f"refining on the FE solver from {first.theta.round(3).tolist()} kPa ...")
            final = fit_parameters(inputs.objective, fe, inputs.eta, theta0=first.theta, f_stop=f_stop)
    check = None
    if check_mesh is not None:
        check, _ = check_mesh_at(inputs.spec, inputs.objective, inputs.eta, final.theta, check_mesh, say)
    if two_level:
        say("the model error at the fit (discrepancy and error budget) ...")
    model_error = model_error_at(inputs.objective, inputs.eta, inputs.surrogate, final.theta)
    return ExperimentFit(inputs, first, final, refine, check, check_mesh, model_error)
