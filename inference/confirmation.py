"""The FE confirmation of a fit (paper 3.4): F(theta_hat) from an FE run against the surrogate's, how
far the surrogate's prediction is from that run, and optionally the mesh check at theta_hat."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..atomic_write import atomic_write_json
from ..design.objective import PAPER_WEIGHTS
from ..forward.predictor import Prediction
from ..surrogate.base import FieldSurrogate
from .budgets.mesh_check import MeshCheck, check_mesh_at
from .experiment.data import ExperimentData
from .fit.inputs import FitInputs, prepare_fit

__all__ = ["Confirmation", "confirm"]


@dataclass
class Confirmation:
    """An FE run at theta beside the surrogate's prediction there.

    Attributes
    ----------
    inputs : FitInputs
        The experiment, surrogate and objective.
    theta : numpy.ndarray
        (c1, c5), kPa.
    solver : str
        ``embedded`` or ``febio``.
    fe : Prediction
        The FE model's response.
    surrogate : Prediction
        The surrogate's.
    mesh_check : MeshCheck or None
        The mesh check, when asked for.
    check_mesh : str or None
        Its finer mesh preset.
    friction : float or None
        The friction coefficient the FE run used (a fit with mu); None: the surrogate's contact.
    """

    inputs: FitInputs
    theta: np.ndarray
    solver: str
    fe: Prediction
    surrogate: Prediction
    mesh_check: MeshCheck | None = None
    check_mesh: str | None = None
    #: the friction coefficient the FE run used (a fit with mu), None for the surrogate's contact
    friction: float | None = None

    def to_dict(self) -> dict:
        """confirm.json: both objective values, the surrogate's largest errors, the mesh check."""
        fe, sur, eta = self.fe, self.surrogate, self.inputs.eta
        u_max = np.abs(fe.displacement[0]).max(axis=(0, 1))
        payload = {
            "F_fe": float(self.inputs.objective.value(fe, eta)[0]),
            "F_surrogate": float(self.inputs.objective.value(sur, eta)[0]),
            "force_diff_max_pct": float(100 * np.abs(sur.force[0] / fe.force[0] - 1).max()),
            "displacement_diff_max_pct": float(
                100 * (np.abs(sur.displacement[0] - fe.displacement[0]) / u_max).max()
            ),
            "solver": self.solver,
            "contact": self.fe_spec.contact.describe(),
        }
        if self.mesh_check is not None:
            payload["mesh_check"] = self.mesh_check.to_dict(self.check_mesh)
        payload["inputs"] = {
            **self.inputs.sources,
            "theta": self.theta.tolist(),
            "weights": eta.tolist(),
            "model": self.fe_spec.to_dict(),
            "fe_stage_model": self.inputs.fe_stage_words() if self.solver == "embedded" else self.solver,
        }
        return payload

    @property
    def fe_spec(self):
        """The model the FE run solved, with the friction coefficient if given.

        The surrogate's FE model; a multi-fidelity one's low level (corrected by its discrepancy:
        ``FitInputs.fe_model``) when the embedded solver ran.
        """
        spec = self.inputs.fe_stage_spec if self.solver == "embedded" else self.inputs.spec
        return spec if self.friction is None else spec.with_friction(self.friction)

    def save(self, folder: str | Path) -> Path:
        """Write ``folder/confirm.json`` atomically (``posterior --mesh-check`` reads it).

        Parameters
        ----------
        folder : str or pathlib.Path
            The folder.

        Returns
        -------
        pathlib.Path
            The file written.
        """
        return atomic_write_json(Path(folder) / "confirm.json", self.to_dict())


def confirm(
    experiment: str | Path | ExperimentData,
    surrogate: str | Path | FieldSurrogate | None,
    theta,
    *,
    weights=PAPER_WEIGHTS,
    solver: str = "embedded",
    check_mesh: str | None = None,
    exclude_steps=(),
    say: Callable[[str], None] | None = None,
    friction: float | None = None,
    reading: str = "fit",
    tests: str | Path | None = None,
) -> Confirmation:
    """Run the surrogate's FE model at ``theta`` and compare it with the surrogate (FE confirmation).

    Parameters
    ----------
    experiment : str, pathlib.Path or ExperimentData
        The experiment (folder or loaded).
    surrogate : str, pathlib.Path, FieldSurrogate or None
        The surrogate (file or loaded); its FE model is run. None: the one shipped for the
        experiment's test (:func:`~indentation_studio.inference.fit.inputs.prepare_fit`).
    theta : array_like
        (c1, c5), kPa.
    weights : array_like, default PAPER_WEIGHTS
        The weights of eq. 5.
    solver : {"embedded", "febio"}, default "embedded"
        The FE solver.
    check_mesh : str, optional
        A finer mesh preset (embedded only): also the finer mesh's shift of the fit and its
        uncertainty.
    exclude_steps : sequence of int, default ()
        Steps (1..N) left out.
    say : callable, optional
        Where progress messages go.
    friction : float, optional
        Run with this Coulomb friction coefficient (the mu of a fit that marginalised or
        identified it; fit.json's ``friction.mu``) instead of the surrogate's contact.
    reading : str, default "fit"
        The objective (eq. 4's reading): the fit's (DIC from 1.5 R) or ``paper``; as the fit's.

    tests : str or pathlib.Path, optional
        A prepared test's folder (``indent-studio test prepare``) read before the shipped surrogates
        (:func:`~indentation_studio.surrogate.shipped.find_test`).
    Returns
    -------
    Confirmation
        Both responses and the mesh check.

    Raises
    ------
    ValueError
        If theta is not (c1, c5), mu is negative or missing for a surrogate over mu, friction is
        combined with a mesh check, or a mesh check is asked of FEBio.
    """
    inputs = prepare_fit(experiment, surrogate, weights, exclude_steps, reading=reading, tests=tests)
    if surrogate is None and say is not None:
        say(f"surrogate: {inputs.sources['surrogate']}")
    theta = np.asarray(theta, float).reshape(-1)
    if theta.size != 2:
        raise ValueError(f"confirm takes theta = (c1, c5); give mu as friction, got {theta.tolist()}")
    if friction is not None and not (np.isfinite(friction) and friction >= 0):
        raise ValueError(f"friction: mu must be a number >= 0, got {friction!r}")
    if friction is not None and check_mesh is not None:
        raise ValueError("friction: the mesh check is made with the perfect stick; confirm without it")
    with_mu = "mu" in inputs.surrogate.parameters
    if with_mu and friction is None:
        raise ValueError(
            f"friction: this surrogate is over {tuple(inputs.surrogate.parameters)}; give mu (--friction), "
            "e.g. the fit's"
        )
    at = np.append(theta, friction) if with_mu else theta  # where the surrogate is compared
    check = None
    if check_mesh is None:
        fe = inputs.fe_model(friction=friction, solver=solver).predict(theta[None, :])
    else:
        if solver != "embedded":
            raise ValueError("the mesh check needs the embedded solver (exact sensitivities)")
        check, fe = check_mesh_at(inputs.spec, inputs.objective, inputs.eta, theta, check_mesh, say)
    return Confirmation(
        inputs,
        theta,
        solver=solver,
        fe=fe,
        surrogate=inputs.surrogate.predict(at[None, :]),
        mesh_check=check,
        check_mesh=check_mesh,
        friction=friction,
    )
