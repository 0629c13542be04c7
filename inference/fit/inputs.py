"""What every inference workflow starts from: a measured experiment, the surrogate that emulates the
FE model, that model's spec, and the objective of eq. 4 and 5 built on the surrogate's top nodes."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...design.objective import PAPER_WEIGHTS, Objective, check_weights
from ...forward.fe_predictor import FESolverPredictor
from ...forward.spec import ModelSpec
from ...surrogate.base import FieldSurrogate
from ...surrogate.persistence import load_surrogate
from ...surrogate.shipped import find_test, load_shipped, recipe_for_test
from ..budgets.model_error import has_high_fidelity_level
from ..experiment.data import ExperimentData, load_experiment
from ..experiment.processing import RegisteredDIC, experiment_objective

__all__ = ["FitInputs", "prepare_fit", "surrogate_fe_model"]


@dataclass
class FitInputs:
    """What a fit needs: the experiment, the surrogate and the FE model it emulates, the objective.

    Attributes
    ----------
    experiment : ExperimentData
        The experiment.
    surrogate : FieldSurrogate
        The surrogate.
    spec : ModelSpec
        The FE model the surrogate was trained on (for the FE stage).
    objective : Objective
        The objective (eq. 4, 5) on the surrogate's top nodes.
    dic : RegisteredDIC
        The DIC data registered to the model frame.
    eta : numpy.ndarray
        (4,) the weights of eq. 5.
    sources : dict of str to str
        Where the experiment and the surrogate came from (provenance).
    """

    experiment: ExperimentData
    surrogate: FieldSurrogate
    spec: ModelSpec  # the FE model the surrogate was trained on (for the FE stage)
    objective: Objective
    dic: RegisteredDIC  # the DIC data registered to the model frame
    eta: np.ndarray
    sources: dict[str, str]  # where the experiment and the surrogate came from (provenance)

    @property
    def corrects_a_low_level(self) -> bool:
        """Whether the surrogate is a low level corrected toward a high fidelity (multi-fidelity)."""
        return has_high_fidelity_level(self.surrogate)

    @property
    def fe_stage_spec(self) -> ModelSpec:
        """The FE model a fit's FE stage solves.

        The surrogate's own; for a multi-fidelity surrogate its low level's (corrected by the
        discrepancy, :meth:`fe_model`).
        """
        if not self.corrects_a_low_level:
            return self.spec
        return ModelSpec.from_dict(self.surrogate.low.meta["campaign"]["model"])

    def fe_model(self, *, friction: float | None = None, with_mu: bool = False, solver: str = "embedded"):
        """The model a fit's FE stage runs (paper 2.8.2): the FE model the surrogate emulates.

        For a multi-fidelity surrogate, its low level's FE model corrected by its discrepancy
        (:meth:`~indentation_studio.surrogate.multi_fidelity.MultiFidelitySurrogate.corrected`):
        one run of the low level (seconds) in place of one of the high fidelity (minutes to an
        hour), so that the FE stage checks the low surrogate's own error and the discrepancy's
        uncertainty stays in the bounds (docs/explanation/model-error.md).

        Parameters
        ----------
        friction : float, optional
            Hold mu at this value (the model over (c1, c5)).
        with_mu : bool, default False
            The model over (c1, c5, mu).
        solver : str, default "embedded"
            The FE solver (``febio``: the surrogate's own FE model, never corrected).

        Returns
        -------
        Predictor
            An FE predictor, or the low level's corrected by the discrepancy.
        """
        return surrogate_fe_model(self.surrogate, friction=friction, with_mu=with_mu, solver=solver)

    def fe_stage_words(self) -> str:
        """The FE stage's model in words (``contact-L1 corrected toward contact-L3``)."""
        high = self.spec.mesh.preset or "its FE model"
        if not self.corrects_a_low_level:
            return high
        return f"{self.fe_stage_spec.mesh.preset} corrected by the learned discrepancy toward {high}"


def surrogate_fe_model(
    surrogate: FieldSurrogate,
    *,
    friction: float | None = None,
    with_mu: bool = False,
    solver: str = "embedded",
):
    """The FE model a surrogate emulates, as a fit's FE stage runs it (paper 2.8.2).

    For a multi-fidelity surrogate, its low level's FE model corrected by its discrepancy
    (:meth:`~indentation_studio.surrogate.multi_fidelity.MultiFidelitySurrogate.corrected`); with
    ``solver="febio"`` the surrogate's own FE model, never corrected.

    Parameters
    ----------
    surrogate : FieldSurrogate
        The surrogate.
    friction : float, optional
        Hold mu at this value (the model over (c1, c5)); None: the model's own contact.
    with_mu : bool, default False
        The model over (c1, c5, mu).
    solver : str, default "embedded"
        The FE solver.

    Returns
    -------
    Predictor
        An FE predictor, or the low level's corrected by the discrepancy.
    """
    corrected = has_high_fidelity_level(surrogate) and solver == "embedded"
    source = surrogate.low if corrected else surrogate
    spec = ModelSpec.from_dict(source.meta["campaign"]["model"])
    if friction is not None:
        spec = spec.with_friction(friction)
    parameters = ("c1", "c5", "mu") if with_mu else ("c1", "c5")
    fe = FESolverPredictor(spec, parameters=parameters, solver=solver)
    return surrogate.corrected(fe) if corrected else fe


def prepare_fit(
    experiment: str | Path | ExperimentData,
    surrogate: str | Path | FieldSurrogate | None = None,
    weights=PAPER_WEIGHTS,
    exclude_steps=(),
    *,
    reading: str = "fit",
    tests: str | Path | None = None,
) -> FitInputs:
    """Load the experiment and the surrogate, check they describe the same test, build the objective.

    The test is the indenter radius, steps and depths; the objective (eq. 4, 5) is built on the
    surrogate's top nodes.

    Parameters
    ----------
    experiment : str, pathlib.Path or ExperimentData
        The experiment (folder or loaded).
    surrogate : str, pathlib.Path, FieldSurrogate or None
        The surrogate (file or loaded); None: the one shipped for the experiment's test
        or prepared for the experiment's test (:func:`~indentation_studio.surrogate.shipped.find_test`:
        ``tests``, the folders of ``INDENTATION_STUDIO_TESTS``, then the shipped ones), checked
        against its manifest's sha256.
    weights : array_like, default PAPER_WEIGHTS
        eta = (force, ux, uy, uz) on the simplex (eq. 5).
    exclude_steps : sequence of int, default ()
        Steps (1..N) left out of the fit beside those experiment.json excludes.
    reading : str, default "fit"
        How eq. 4 is read (:class:`~indentation_studio.design.objective.Objective`): the fit's
        objective, DIC from 1.5 R; ``paper`` for the paper's, from 1 R.
    tests : str or pathlib.Path, optional
        A prepared test's folder (``indent-studio test prepare``) read before the shipped surrogates.

    Returns
    -------
    FitInputs
        The experiment, surrogate, FE model, objective and weights.

    Raises
    ------
    ValueError
        If the surrogate does not record its model, or the two describe different tests, or
        none is given and none is shipped for the experiment's test (the message says what to run).
    """
    eta = check_weights(weights)
    exp = experiment if isinstance(experiment, ExperimentData) else load_experiment(experiment)
    model, label = _surrogate_for(exp, surrogate, tests)
    campaign = model.meta.get("campaign") or {}
    if "model" not in campaign:
        raise ValueError(f"{label}: the surrogate does not record the model it was trained on")
    spec = ModelSpec.from_dict(campaign["model"])
    if (
        abs(spec.indenter.radius - exp.radius) > 1e-6
        or len(model.depth) != exp.steps
        or not np.allclose(model.depth, exp.depths)
    ):
        raise ValueError(
            f"the experiment (R = {exp.radius:g} mm, {exp.steps} x {exp.step_size:g} mm) does not match the "
            f"surrogate's model (R = {spec.indenter.radius:g} mm, {len(model.depth)} steps to {model.depth[-1]:g} mm)"
        )
    stated, modelled = exp.block, spec.to_dict()["geometry"]
    if stated is not None and any(abs(stated[k] - float(modelled[k])) > 1e-6 for k in stated):
        raise ValueError(
            f"the experiment's specimen ({exp.specimen_mm}) is not the surrogate's model's "
            f"({2 * modelled['half_x']:g} x {2 * modelled['half_y']:g} x {modelled['height']:g} mm)"
        )
    objective, dic = experiment_objective(exp, model.top_xyz, reading=reading, excluded_steps=exclude_steps)
    sources = {"experiment": str(exp.root), "surrogate": label}
    if "shipped" in model.meta:
        sources["surrogate_sha256"] = model.meta["shipped"]["sha256"]
    return FitInputs(exp, model, spec, objective, dic, eta, sources)


def _surrogate_for(
    exp: ExperimentData, surrogate: str | Path | FieldSurrogate | None, tests: str | Path | None = None
) -> tuple[FieldSurrogate, str]:
    """The surrogate a fit of ``exp`` runs on and how it is named in its provenance."""
    if isinstance(surrogate, FieldSurrogate):
        return surrogate, f"{surrogate.kind} surrogate (in memory)"
    if surrogate is not None:
        return load_surrogate(surrogate), str(surrogate)
    entry = find_test(exp.radius, exp.depths, tests=tests, block=exp.block)
    if entry is None:
        raise ValueError(f"{exp.root}: {recipe_for_test(exp.radius, exp.depths)}")
    return load_shipped(entry), entry.describe()
