"""The Predictor of the FE model (docs/architecture.md, "The Predictor seam"): one simulation
per parameter point, by the embedded solver (with its exact sensitivities when asked) or by FEBio.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from .febio.runner import FebioSolver, find_febio
from .predictor import Prediction, as_theta
from .result import SimulationResult
from .solver import simulate
from .spec import ModelSpec, SpecError

__all__ = ["FESolverPredictor"]


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
