"""The one seam (docs/architecture.md, "The Predictor seam"): a Predictor maps parameters to force curves and fields.

``predict(theta (n, p), kPa) -> Prediction(force (n, steps) mN, displacement (n, steps, nodes, 3) mm)``.
The steps are the indentation steps 1..N_s (depth 0, where everything is zero, is left out, so
that relative force errors, eq. 4a, are defined at every step). ``theta``'s columns are named by
the Predictor's ``parameters``; nothing downstream assumes p = 2.

:class:`forward.fe_predictor.FESolverPredictor` runs the embedded FE solver (with its exact
sensitivities when asked) or FEBio; the surrogates implement the same protocol.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Protocol, runtime_checkable

import numpy as np

from .result import SimulationResult


@dataclass
class Prediction:
    """Force curves and top-surface displacement fields for n parameter points.

    Attributes
    ----------
    force : numpy.ndarray
        (n, steps) indentation force of the whole specimen, mN.
    displacement : numpy.ndarray
        (n, steps, nodes, 3) top-surface displacements, mm.
    depth : numpy.ndarray
        (steps,) indentation depth, mm (depth 0 left out).
    top_xyz : numpy.ndarray
        (nodes, 3) reference coordinates of the top-surface nodes, mm.
    parameters : tuple of str, default ("c1", "c5")
        The parameters of theta.
    force_jacobian : numpy.ndarray or None
        (n, steps, p) d force / d theta, mN/kPa.
    displacement_jacobian : numpy.ndarray or None
        (n, steps, nodes, 3, p) d u / d theta, mm/kPa.
    """

    force: np.ndarray  # (n, steps) mN, whole specimen
    displacement: np.ndarray  # (n, steps, nodes, 3) mm
    depth: np.ndarray  # (steps,) mm
    top_xyz: np.ndarray  # (nodes, 3) reference coordinates, mm
    parameters: tuple[str, ...] = ("c1", "c5")
    force_jacobian: np.ndarray | None = None  # (n, steps, p) mN/kPa
    displacement_jacobian: np.ndarray | None = None  # (n, steps, nodes, 3, p) mm/kPa

    @property
    def n(self) -> int:
        """The number of points."""
        return int(self.force.shape[0])

    @classmethod
    def from_results(cls, results: list[SimulationResult], parameters: tuple[str, ...]) -> Prediction:
        """Stack simulation results (depth 0 dropped) into one Prediction.

        Parameters
        ----------
        results : list of SimulationResult
            One per point, same steps and nodes.
        parameters : tuple of str
            The Jacobians keep these columns (a run with friction has d/dmu beside d/d(c1, c5),
            used when mu is a parameter and left out when it is fixed).

        Returns
        -------
        Prediction
            The stacked responses.

        Raises
        ------
        ValueError
            If the simulations have no sensitivities with respect to a parameter.
        """
        first = results[0]
        sens = all(r.force_sensitivity is not None for r in results)
        columns = None
        if sens:
            missing = [k for k in parameters if k not in first.parameters]
            if missing:
                raise ValueError(f"the simulations have no sensitivities with respect to {missing}")
            columns = [list(first.parameters).index(k) for k in parameters]
        return cls(
            force=np.stack([r.force[1:] for r in results]),
            displacement=np.stack([r.displacement[1:] for r in results]),
            depth=np.asarray(first.depth[1:]),
            top_xyz=np.asarray(first.top_xyz),
            parameters=parameters,
            force_jacobian=np.stack([r.force_sensitivity[1:, columns] for r in results]) if sens else None,
            displacement_jacobian=np.stack([r.displacement_sensitivity[1:, ..., columns] for r in results])
            if sens
            else None,
        )


@runtime_checkable
class Predictor(Protocol):
    """Anything that predicts force curves and fields from parameters: the FE solvers and surrogates.

    See docs/architecture.md, "The Predictor seam".

    Attributes
    ----------
    parameters : tuple of str
        The parameters of theta, e.g. ``("c1", "c5")``.
    """

    parameters: tuple[str, ...]

    def predict(self, theta: np.ndarray, jacobian: bool = False) -> Prediction:
        """Force curves and fields at ``theta``; with ``jacobian`` their derivatives too.

        Parameters
        ----------
        theta : numpy.ndarray
            (n, p) points.
        jacobian : bool, default False
            Also d force / d theta and d u / d theta.

        Returns
        -------
        Prediction
            The responses.
        """
        ...


@dataclass(frozen=True)
class ReducedBasis:
    """A Predictor's outputs as affine maps of a few reduced coordinates (a surrogate's PCA scores).

        log force (n, steps)                = force_mean + z_force @ force_basis
        displacement (n, steps * nodes * 3) = field_mean + z_field @ field_basis

    with ``(z_force, z_field) = coordinates(theta)`` for theta (n, p). Whatever is linear in the
    field (the displacement residuals of eq. 4b) can then be evaluated in the reduced space
    without rebuilding the field (design/reduced_objective.py).

    Attributes
    ----------
    force_mean : numpy.ndarray
        (steps,) mean log force, log mN.
    force_basis : numpy.ndarray
        (k_force, steps) the force's components.
    field_mean : numpy.ndarray
        (steps * nodes * 3,) mean displacement field, mm.
    field_basis : numpy.ndarray
        (k_field, steps * nodes * 3) the field's components.
    steps, nodes : int
        The field's steps and top nodes.
    coordinates : callable
        theta (n, p) -> (z_force, z_field).
    """

    force_mean: np.ndarray  # (steps,) log mN
    force_basis: np.ndarray  # (k_force, steps)
    field_mean: np.ndarray  # (steps * nodes * 3,) mm
    field_basis: np.ndarray  # (k_field, steps * nodes * 3)
    steps: int
    nodes: int
    coordinates: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]


@runtime_checkable
class ReducedPredictor(Predictor, Protocol):
    """A Predictor that can also give its outputs as a :class:`ReducedBasis` (the surrogates).

    Attributes
    ----------
    parameters : tuple of str
        The parameters of theta.
    """

    def reduced_basis(self) -> ReducedBasis:
        """The affine reduced form of :meth:`predict` (without Jacobians)."""
        ...


def as_theta(theta: np.ndarray | list, p: int) -> np.ndarray:
    """``theta`` as a finite (n, p) float array; one point may be given as (p,)."""
    t = np.atleast_2d(np.asarray(theta, dtype=float))
    if t.ndim != 2 or t.shape[1] != p:
        raise ValueError(f"theta must have {p} columns, got shape {np.shape(theta)}")
    if not np.all(np.isfinite(t)):
        raise ValueError("theta holds NaN or infinite values")
    return t


class CachedPredictor:
    """A Predictor that remembers its answers point by point (with or without Jacobians).

    For callers that ask an expensive FE model the same point more than once (an error budget
    that fits several models built on the same meshes). Other attributes are the wrapped
    predictor's.

    Parameters
    ----------
    predictor : Predictor
        The predictor to remember.
    """

    def __init__(self, predictor) -> None:
        self.predictor = predictor
        self.parameters = tuple(predictor.parameters)
        self._rows: dict[bytes, tuple[Prediction, bool]] = {}

    def __getattr__(self, name: str):
        return getattr(self.predictor, name)

    def predict(self, theta: np.ndarray, jacobian: bool = False) -> Prediction:
        """The wrapped predictor's response, points already asked (with Jacobians if needed) remembered.

        Parameters
        ----------
        theta : numpy.ndarray
            (n, p) points.
        jacobian : bool, default False
            Also the Jacobians.

        Returns
        -------
        Prediction
            The responses, in the order of ``theta``.
        """
        t = as_theta(theta, len(self.parameters))
        keys = [row.tobytes() for row in t]
        missing = [
            i for i, k in enumerate(keys) if k not in self._rows or (jacobian and not self._rows[k][1])
        ]
        if missing:
            fresh = self.predictor.predict(t[missing], jacobian=jacobian)
            for j, i in enumerate(missing):
                self._rows[keys[i]] = (_row(fresh, j), jacobian)
        rows = [self._rows[k][0] for k in keys]

        def stacked(name: str) -> np.ndarray | None:
            return (
                np.concatenate([getattr(r, name) for r in rows])
                if jacobian or "jacobian" not in name
                else None
            )

        first = rows[0]
        return Prediction(
            stacked("force"),
            stacked("displacement"),
            first.depth,
            first.top_xyz,
            first.parameters,
            stacked("force_jacobian"),
            stacked("displacement_jacobian"),
        )


def _row(prediction: Prediction, i: int) -> Prediction:
    """Point ``i`` of a Prediction as a one-point Prediction."""

    def pick(a: np.ndarray | None) -> np.ndarray | None:
        return None if a is None else a[i : i + 1]

    return replace(
        prediction,
        force=pick(prediction.force),
        displacement=pick(prediction.displacement),
        force_jacobian=pick(prediction.force_jacobian),
        displacement_jacobian=pick(prediction.displacement_jacobian),
    )


class FixedParameter:
    """A Predictor over all but one of another predictor's parameters, that one held at ``value``.

    E.g. mu known, on a surrogate trained with mu as a parameter.

    Parameters
    ----------
    predictor : Predictor
        The predictor over all the parameters.
    name : str
        The parameter to hold (e.g. ``"mu"``).
    value : float
        Its value.

    Raises
    ------
    ValueError
        If the predictor has no parameter ``name``.
    """

    def __init__(self, predictor, name: str, value: float) -> None:
        names = tuple(predictor.parameters)
        if name not in names:
            raise ValueError(f"the predictor has no parameter {name!r} (it has {names})")
        self.predictor = predictor
        self.index = names.index(name)
        self.value = float(value)
        self.parameters = tuple(k for k in names if k != name)

    def predict(self, theta, jacobian: bool = False) -> Prediction:
        """The wrapped predictor's response with the held parameter inserted.

        Parameters
        ----------
        theta : array_like
            (n, p - 1) the other parameters.
        jacobian : bool, default False
            Also the Jacobians (the held parameter's column left out).

        Returns
        -------
        Prediction
            Over the other parameters.
        """
        t = as_theta(theta, len(self.parameters))
        full = np.insert(t, self.index, self.value, axis=1)
        pred = self.predictor.predict(full, jacobian=jacobian)
        keep = [i for i in range(full.shape[1]) if i != self.index]
        return Prediction(
            pred.force,
            pred.displacement,
            pred.depth,
            pred.top_xyz,
            self.parameters,
            None if pred.force_jacobian is None else pred.force_jacobian[..., keep],
            None if pred.displacement_jacobian is None else pred.displacement_jacobian[..., keep],
        )
