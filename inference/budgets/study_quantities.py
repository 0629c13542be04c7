"""The quantities a verification study reads from each level's run
(:mod:`inference.budgets.verification_study`): the indenter force at a few depths, the top field at
rings around the axis, and the parameter bias, the (c1, c5) that one Gauss-Newton step of the
objective (eq. 4, 5) fits to a level's noise-free response.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from ...design.objective import PAPER_WEIGHTS, Objective
from ...forward.convergence.mesh_study import top_field_interpolator
from ...forward.predictor import Prediction
from ...forward.result import SimulationResult
from .mesh_check import prediction_at_nodes

__all__ = [
    "FIELD_RINGS",
    "FIT_FIELD_OF_VIEW",
    "FORCE_DEPTHS",
    "field_quantities",
    "parameter_bias",
    "step_at",
]

#: Depths at which the force is studied (mm), and rings (multiples of R) where the field is.
FORCE_DEPTHS = (2.0, 7.0, 14.0)
FIELD_RINGS = (1.0, 1.5, 2.0, 3.0)
#: The field of view of the fit whose bias is studied (mm from the axis), as the synthetic
#: experiments' DIC (inference.experiment.synthetic.LAB_RECORDING).
FIT_FIELD_OF_VIEW = 25.0


def step_at(result: SimulationResult, depth: float) -> int | None:
    """The step of ``result`` at ``depth`` (mm), or None where its protocol does not reach it.

    Parameters
    ----------
    result : SimulationResult
        A run.
    depth : float
        The depth, mm.

    Returns
    -------
    int or None
    """
    hit = np.flatnonzero(np.isclose(result.depth, depth, atol=1e-9))
    return int(hit[0]) if hit.size else None


def field_quantities(result: SimulationResult, radius: float) -> dict[str, float]:
    """uz and ux on the x axis and uy on the y axis at the rings, deepest step, mm.

    Parameters
    ----------
    result : SimulationResult
        A run.
    radius : float
        The indenter's radius, mm (the rings are multiples of it: :data:`FIELD_RINGS`).

    Returns
    -------
    dict of str to float
        ``uz(<ring>R)``, ``ux(<ring>R)`` and ``uy(<ring>R)``.
    """
    at = top_field_interpolator(result.top_xyz, result.displacement[-1])
    out = {}
    for ring in FIELD_RINGS:
        rho = ring * radius
        on_x, on_y = at(np.array([[rho, 0.0]]))[0], at(np.array([[0.0, rho]]))[0]
        out[f"uz({ring:g}R)"] = float(on_x[2])
        out[f"ux({ring:g}R)"] = float(on_x[0])
        out[f"uy({ring:g}R)"] = float(on_y[1])
    return out


def parameter_bias(
    model: SimulationResult,
    data: SimulationResult,
    *,
    weights: Sequence[float] = PAPER_WEIGHTS,
    field_of_view: float = FIT_FIELD_OF_VIEW,
    reading: str = "fit",
    jacobian_from: SimulationResult | None = None,
) -> np.ndarray:
    """The (c1, c5) one Gauss-Newton step of the objective (eq. 4, 5) fits to ``data``'s response.

    The step is in log theta, from ``model`` solved at the truth with sensitivities (or with those
    of ``jacobian_from``); the data are noise-free.

    Parameters
    ----------
    model : SimulationResult
        The fitting model at the true parameters, with sensitivities (its mesh's top nodes are
        the objective's nodes).
    data : SimulationResult
        The response fitted (another mesh of the same test), read at ``model``'s top nodes.
    weights : four numbers, optional
        eta of eq. 5 (force, ux, uy, uz); the paper's by default.
    field_of_view : float, optional
        Nodes farther than this from the axis carry no data (mm).
    reading : str, default "fit"
        How eq. 4 is read (:class:`Objective`): the fit's objective (DIC from 1.5 R) by default;
        ``paper`` for the paper's rings from 1 R.
    jacobian_from : SimulationResult, optional
        Another mesh of the same test at the same parameters, with sensitivities, whose Jacobian
        (interpolated at ``model``'s top nodes) takes the place of ``model``'s own; ``model``
        then needs none.

    Returns
    -------
    numpy.ndarray
        (c1, c5) in kPa; ``model``'s own parameters when ``data`` is ``model``.

    Raises
    ------
    ValueError
        If the Jacobian's source was solved without sensitivities, or at other parameters.
    """
    source = model if jacobian_from is None else jacobian_from
    if source.force_sensitivity is None:
        raise ValueError("the fitting model must be solved with sensitivities")
    if source.spec["material"] != model.spec["material"]:
        raise ValueError("the Jacobian's source must be solved at the fitting model's parameters")
    theta = np.array([model.spec["material"]["c1"], model.spec["material"]["c5"]], float)
    top = np.asarray(model.top_xyz)
    target = prediction_at_nodes(data, top)
    radius = float(model.spec["indenter"]["radius"])
    mask = np.hypot(top[:, 0], top[:, 1]) <= field_of_view
    objective = Objective(target.force[0], target.displacement[0], top, radius, mask=mask, reading=reading)
    pred = Prediction.from_results([source], ("c1", "c5"))
    if jacobian_from is not None:
        field = np.moveaxis(pred.displacement_jacobian[0], 1, 0)  # (nodes, steps, 3, p)
        at_top = np.moveaxis(top_field_interpolator(pred.top_xyz, field)(top), 0, 1)
        own = Prediction.from_results([model], ("c1", "c5"))
        pred = replace(own, force_jacobian=pred.force_jacobian, displacement_jacobian=at_top[None])
    r = objective.residuals(pred, weights)[0]
    J = objective.jacobian(pred, weights)[0] * theta
    delta, *_ = np.linalg.lstsq(J, -r, rcond=None)
    return theta * np.exp(delta)
