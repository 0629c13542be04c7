"""The one seam (docs/architecture.md, "The Predictor seam"): a Predictor maps parameters to force curves and fields.

``predict(theta (n, p), kPa) -> Prediction(force (n, steps) mN, displacement (n, steps, nodes, 3) mm)``.
The steps are the indentation steps 1..N_s (depth 0, where everything is zero, is left out, so
that relative force errors, eq. 4a, are defined at every step). ``theta``'s columns are named by
the Predictor's ``parameters``; nothing downstream assumes p = 2.

:class:`FESolverPredictor` runs the embedded FE solver (with its exact sensitivities when asked)
or FEBio; the surrogates implement the same protocol.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Protocol, runtime_checkable

import numpy as np

from .febio.runner import FebioSolver, find_febio
from .result import SimulationResult
from .solver import simulate
from .spec import ModelSpec, SpecError


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


class FESolverPredictor:
    """A Predictor that runs one FE simulation per parameter point.

    ``solver`` is ``"embedded"`` (sensitivities available: exact d force / d theta and
    d u / d theta from the solver) or ``"febio"`` (needs FEBio 4, see forward.febio.runner;
    steps FEBio accepted off equilibrium, even after its rerun, come back with NaN forces).
    ``n_jobs`` > 1 runs points in parallel with joblib processes.

    Parameters
    ----------
    spec : ModelSpec
        The model; each point sets its parameters.
    solver : {"embedded", "febio"}, default "embedded"
        The FE solver.
    sensitivities : bool, default False
        Solve for the exact sensitivities too (embedded solver only).
    parameters : tuple of str, default ("c1", "c5")
        ``("c1", "c5")`` or ``("c1", "c5", "mu")``.
    n_jobs : int, default 1
        Points solved in parallel.
    workdir : str or pathlib.Path, optional
        FEBio: a folder per point (``point-<index>``) under it.

    Raises
    ------
    ValueError
        If the solver is unknown, sensitivities are asked of FEBio, or the parameters are others.

    Examples
    --------
    >>> import indentation_studio as ins
    >>> fe = ins.FESolverPredictor(ins.ModelSpec(), sensitivities=True)
    >>> pred = fe.predict([[10.0, 350.0]], jacobian=True)  # doctest: +SKIP
    >>> pred.force_jacobian.shape  # doctest: +SKIP
    """

    def __init__(
        self,
        spec: ModelSpec,
        solver: str = "embedded",
        sensitivities: bool = False,
        parameters: tuple[str, ...] = ("c1", "c5"),
        n_jobs: int = 1,
        workdir: str | Path | None = None,
    ) -> None:
        if solver not in ("embedded", "febio"):
            raise ValueError(f"unknown solver {solver!r}; use 'embedded' or 'febio'")
        if sensitivities and solver != "embedded":
            raise ValueError("exact sensitivities come from the embedded solver only")
        if tuple(parameters) not in (("c1", "c5"), ("c1", "c5", "mu")):
            raise ValueError(
                f"the FE solvers take parameters ('c1', 'c5') or ('c1', 'c5', 'mu'), got {parameters}"
            )
        if solver == "febio":
            find_febio()  # fail now, with the FEBIO_PATH message, not inside a worker
        self.spec = spec
        self.solver = solver
        self.sensitivities = sensitivities
        self.parameters = tuple(parameters)
        self.n_jobs = n_jobs
        self.workdir = Path(workdir) if workdir else None

    def spec_at(self, point: np.ndarray) -> ModelSpec:
        """The model spec at one parameter point.

        Parameters
        ----------
        point : numpy.ndarray
            (p,) values of ``parameters``.

        Returns
        -------
        ModelSpec
            The spec with those values (a bad value raises SpecError naming it).
        """
        return self.spec.with_parameters(**{k: float(v) for k, v in zip(self.parameters, point, strict=True)})

    def simulate(self, point: np.ndarray, index: int = 0, sensitivities: bool = False) -> SimulationResult:
        """One simulation at one point.

        Parameters
        ----------
        point : numpy.ndarray
            (p,) the parameters.
        index : int, default 0
            The point's number (FEBio: its folder ``point-<index>`` under ``workdir``).
        sensitivities : bool, default False
            Solve for the sensitivities too (embedded solver).

        Returns
        -------
        SimulationResult
            The result.
        """
        spec = self.spec_at(point)
        if self.solver == "embedded":
            return simulate(spec, sensitivities=self.sensitivities or sensitivities)
        workdir = self.workdir / f"point-{index:05d}" if self.workdir else None
        return FebioSolver(spec, workdir=workdir).run()

    def predict(self, theta: np.ndarray, jacobian: bool = False) -> Prediction:
        """Force curves and fields at ``theta``: one simulation per point.

        Parameters
        ----------
        theta : numpy.ndarray
            (n, p) points (kPa; mu unitless).
        jacobian : bool, default False
            Ask the embedded solver for its exact sensitivities (FEBio gives none).

        Returns
        -------
        Prediction
            Forces, fields and, if asked, their Jacobians (depth 0 dropped).

        Raises
        ------
        ValueError
            If a Jacobian is asked of FEBio.
        SpecError
            If a point's value is invalid (every point is checked before any is solved).
        """
        t = as_theta(theta, len(self.parameters))
        if jacobian and self.solver != "embedded":
            raise ValueError("exact sensitivities come from the embedded solver only")
        for point in t:
            self.spec_at(point)  # validate every point before any is solved
        if self.n_jobs == 1 or len(t) == 1:
            results = [self.simulate(point, i, jacobian) for i, point in enumerate(t)]
        else:
            from joblib import Parallel, delayed

            results = Parallel(n_jobs=self.n_jobs)(
                delayed(self.simulate)(p, i, jacobian) for i, p in enumerate(t)
            )
        return Prediction.from_results(results, self.parameters)

    def with_spec(self, **changes) -> FESolverPredictor:
        """The same predictor on a changed spec.

        Parameters
        ----------
        **changes
            Fields of :class:`ModelSpec` to replace (e.g. ``indenter=Indenter(8.0)``).

        Returns
        -------
        FESolverPredictor
            The new predictor.

        Raises
        ------
        SpecError
            If a field is unknown.
        """
        try:
            spec = replace(self.spec, **changes)
        except TypeError as exc:
            raise SpecError("spec", str(exc)) from exc
        return FESolverPredictor(
            spec, self.solver, self.sensitivities, self.parameters, self.n_jobs, self.workdir
        )


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
