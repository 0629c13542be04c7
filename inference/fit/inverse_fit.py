"""The inverse fit of paper 2.8.2: Levenberg-Marquardt on the residual vector of eq. 4 and 5, then
the certainty bounds of eq. 6 to 8 at the fit.

The residuals come from any Predictor that gives Jacobians (a surrogate, or the embedded solver
with its exact sensitivities), so the same code fits on a surrogate and then refines with the FE
solver in the loop. The unknowns are log(theta), which keeps the moduli positive without bounds
(scipy's 'lm' takes none). The paper stops as soon as F < 3e-2 (``f_stop=PAPER_F_STOP``); by
default the fit runs to LM's own convergence, because F < 3e-2 can hold well before the minimum
(the paper's Table 2 fits end at F = 0.003 to 0.015) and the bounds of eq. 6 belong to the minimum.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.optimize import least_squares

from ...design.certainty import bounds_pct, s_from_data
from ...design.objective import Objective, check_weights
from ...forward.solver import SimulationError

PAPER_START = (6.0, 300.0)
PAPER_F_STOP = 3e-2


@dataclass
class FitResult:
    """The result of an inverse fit: theta_hat, F there, the Hessian, eq. 8's s, eq. 6's bounds.

    Attributes
    ----------
    theta : numpy.ndarray
        (p,) theta_hat, kPa.
    F : float
        F(theta_hat) (eq. 5).
    hessian : numpy.ndarray
        (p, p) the Hessian in theta_bar = theta / theta_hat.
    s : float
        Eq. 8's s.
    bounds_pct : numpy.ndarray
        (p,) eq. 6's bounds, percent of theta_hat.
    n_residuals : int
        Number of residuals n.
    evaluations : int
        Evaluations of F.
    wall_s : float
        Wall time, s.
    message : str
        The optimiser's message.
    history : list of (list of float, float)
        (theta, F) of every evaluation.
    residuals : numpy.ndarray or None
        The residual vector of eq. 5 at theta (what F sums).
    prediction : Prediction or None
        The predictor's response there (without Jacobians).
    jacobian : numpy.ndarray or None
        (m, p) d residuals / d log theta there.
    """

    theta: np.ndarray
    F: float
    hessian: np.ndarray
    s: float
    bounds_pct: np.ndarray
    n_residuals: int
    evaluations: int
    wall_s: float
    message: str
    history: list[tuple[list[float], float]] = field(default_factory=list)
    residuals: np.ndarray | None = None  # the residual vector of eq. 5 at theta (what F sums)
    prediction: object | None = None  # the predictor's response there (a Prediction without Jacobians)
    jacobian: np.ndarray | None = None  # d residuals / d log theta there (m, p)

    @property
    def residual_sd(self) -> float:
        """sqrt(F(theta_hat) / (n - p)): the standard deviation of one normalised residual.

        The noise level of the posterior's likelihood (eq. 8's s is this times the 95 % factor
        sqrt(p F_{p,n-p}^0.95), which would widen a posterior about 2.4 times).
        """
        return float(np.sqrt(self.F / (self.n_residuals - self.theta.size)))

    def interval(self) -> np.ndarray:
        """theta_hat +- the eq. 6 bound (p, 2) in kPa."""
        half = self.theta * self.bounds_pct / 100.0
        return np.stack([self.theta - half, self.theta + half], axis=1)


class _EarlyStop(Exception):
    pass


class _Stalled(Exception):
    pass


#: A fit stops at its best point when, after it has improved on its start, F has not fallen by
#: this fraction of eq. 8's s^2 (the height of eq. 6's certainty region F - F_hat <= s^2) in
#: ``STALL_EVALUATIONS`` evaluations in a row: an objective that is not smooth at the scale of the
#: steps (friction's stick and slip statuses settle differently at parameters 1e-4 apart, F
#: jumping by 15 %) otherwise holds Levenberg-Marquardt to its evaluation limit. A point within
#: 0.01 s^2 of the minimum lies within a tenth of a bound of it (F is quadratic there).
STALL_S2_FRACTION = 0.01
STALL_EVALUATIONS = 8


def fit_parameters(
    objective: Objective,
    predictor,
    eta,
    theta0=PAPER_START,
    f_stop: float | None = None,
    alpha: float = 0.05,
    s: float | None = None,
    max_evaluations: int = 60,
    box: tuple | None = None,
    progress: Callable[[int, np.ndarray, float], None] | None = None,
) -> FitResult:
    """Minimise F(theta) (eq. 5) by Levenberg-Marquardt from ``theta0``, with eq. 6 bounds.

    Parameters
    ----------
    objective : Objective
        The target (eq. 4a, 4b).
    predictor : Predictor
        The model (a surrogate or an FE solver).
    eta : array_like
        The weights of eq. 5.
    theta0 : array_like, default PAPER_START
        The start, kPa.
    f_stop : float, optional
        Stop as soon as F falls below this (the paper's rule: 3e-2).
    alpha : float, default 0.05
        Eq. 8's level.
    s : float, optional
        Eq. 6's s; default from eq. 8 (n residuals, p parameters, ``alpha``).
    max_evaluations : int, default 60
        Evaluations of F at most.
    box : tuple, optional
        (lo, hi) (0 and inf for no limit) keeps theta inside (a trust-region reflective fit then:
        scipy's 'lm' takes no bounds); e.g. mu within the range a surrogate was trained on.
    progress : callable, optional
        ``progress(k, theta, F)`` is told of every evaluation (an FE model's take minutes).

    Returns
    -------
    FitResult
        theta_hat, F, the Hessian, s and the bounds.

    Raises
    ------
    ValueError
        If the start is not positive moduli, or the box's lower limits are not below its upper ones.
    """
    eta = check_weights(eta)
    theta0 = np.asarray(theta0, float)
    if theta0.ndim != 1 or not np.all(np.isfinite(theta0)) or np.any(theta0 <= 0):
        raise ValueError(f"the start point must be positive moduli, got {theta0.tolist()}")
    t0 = time.perf_counter()
    history: list[tuple[list[float], float]] = []
    last: dict[str, np.ndarray] = {}  # the last evaluated point: LM asks for r and J there in turn

    good: dict[str, np.ndarray] = {}  # the last point whose model ran to the end
    best: dict[str, np.ndarray] = {}  # the lowest F among those
    # the F last fallen to by STALL_S2_FRACTION s^2, evaluations since, falls below the start's
    stall = {"F": np.inf, "since": 0, "falls": 0}
    n_data = objective.data_points(eta)
    failed: list[str] = []
    failed_at: set[bytes] = set()
    seen: dict = {}  # the last prediction residuals_at made

    def evaluate(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if "z" not in last or not np.array_equal(last["z"], z):
            try:
                with np.errstate(over="ignore"):
                    trial = np.exp(z)
                if not np.all(np.isfinite(trial) & (trial > 0)):  # a step that overflowed in log theta
                    raise SimulationError(
                        f"a trial step to {trial.tolist()} leaves the positive numbers", 0.0
                    )
                r, J = residuals_at(objective, predictor, eta, trial, keep=seen)
            except SimulationError as exc:
                if not good:  # nowhere to step back to
                    raise
                # a trial point whose simulation failed (an FE model that does not converge there):
                # answered as ten times worse than the last good point, so that the step is refused
                # and the trust region shrinks, instead of the fit and all it computed being lost
                failed.append(f"{np.round(trial, 4).tolist()}: {exc}")
                failed_at.add(z.tobytes())
                last.update(z=z.copy(), r=np.sqrt(10.0) * good["r"], J=good["J"], pred=None)
                history.append((trial.tolist(), float("inf")))
                if progress is not None:
                    progress(len(history), trial, float("inf"))
                return last["r"], last["J"]
            last.update(z=z.copy(), r=r, J=J, pred=seen.get("prediction"))
            good.update(z=z.copy(), r=r, J=J)
            if not best or r @ r < best["r"] @ best["r"]:
                best.update(z=z.copy(), r=r, J=J, pred=seen.get("prediction"))
            history.append((np.exp(z).tolist(), float(r @ r)))
            if progress is not None:
                progress(len(history), np.exp(z), float(r @ r))
            if f_stop is not None and r @ r < f_stop:
                raise _EarlyStop
            F = float(r @ r)
            s2 = s_from_data(F, n_data, z.size, alpha) ** 2 if n_data > z.size else 0.0
            if F < stall["F"] - STALL_S2_FRACTION * s2:
                stall.update(F=F, since=0, falls=stall["falls"] + int(np.isfinite(stall["F"])))
            else:
                stall["since"] += 1
                if stall["falls"] > 0 and stall["since"] >= STALL_EVALUATIONS:
                    raise _Stalled
        return last["r"], last["J"]

    z = np.log(theta0)
    limits: dict = {"method": "lm"}
    if box is not None:
        with np.errstate(divide="ignore"):
            z_lo, z_hi = (np.broadcast_to(np.log(np.asarray(b, float)), z.shape) for b in box)
        if np.any(z_lo >= z_hi):
            raise ValueError(f"the box's lower limits must lie below its upper ones, got {box}")
        z = np.clip(z, z_lo, z_hi)  # scipy moves a start on a limit just inside
        limits = {"method": "trf", "bounds": (z_lo, z_hi)}
    message = ""
    try:
        sol = least_squares(
            lambda z: evaluate(z)[0],
            z,
            jac=lambda z: evaluate(z)[1],
            x_scale=1.0,
            max_nfev=max_evaluations,
            **limits,
        )
        z, message = sol.x, sol.message
    except _EarlyStop:
        z = last["z"]
        message = f"F < {f_stop:g} (the paper's stopping rule)"
    except _Stalled:
        z = best["z"]
        message = (
            f"stopped at the best point: F fell by less than {STALL_S2_FRACTION:g} s^2 in "
            f"{STALL_EVALUATIONS} evaluations (an objective not smooth at the steps' scale, or at its minimum)"
        )
    if z.tobytes() in failed_at:
        z = best["z"]  # never report a point whose model did not run: the best one that did
    theta = np.exp(z)
    at_best = best and np.array_equal(z, best["z"])
    r, J = (best["r"], best["J"]) if at_best else evaluate(z)
    prediction = best.get("pred") if at_best else last.get("pred")
    if failed:
        message += f"; {len(failed)} trial point(s) whose simulation failed were refused: " + "; ".join(
            failed
        )
    return _fit_result(
        objective,
        eta,
        theta,
        r=r,
        J=J,
        s=s,
        alpha=alpha,
        history=history,
        t0=t0,
        message=message,
        prediction=prediction,
    )


def _fit_result(objective, eta, theta, r, J, s, alpha, history, t0, message, prediction=None) -> FitResult:
    """The FitResult at ``theta`` from its residuals and Jacobian in log theta: F, the Gauss-Newton
    Hessian (log theta is theta_bar - 1 to first order), s of eq. 8 unless given, eq. 6 bounds."""
    F = float(r @ r)
    H = 2.0 * J.T @ J
    n = objective.data_points(eta)
    s_used = s if s is not None else s_from_data(F, n, theta.size, alpha)
    return FitResult(
        theta=theta,
        F=F,
        hessian=H,
        s=s_used,
        bounds_pct=bounds_pct(H, s_used),
        n_residuals=n,
        evaluations=len(history),
        wall_s=time.perf_counter() - t0,
        message=message,
        history=history,
        residuals=np.asarray(r, float).copy(),
        prediction=prediction,
        jacobian=np.asarray(J, float).copy(),
    )


def residuals_at(
    objective: Objective, predictor, eta, theta: np.ndarray, keep: dict | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Residuals (m,) at ``theta`` and their Jacobian with respect to log(theta) (m, p);
    ``keep['prediction']`` is set to the response there (without its Jacobians) when given."""
    pred = predictor.predict(theta[None, :], jacobian=True)
    if keep is not None:
        keep["prediction"] = replace(pred, force_jacobian=None, displacement_jacobian=None)
    return objective.residuals(pred, eta)[0], objective.jacobian(pred, eta)[0] * theta


def gauss_newton_refine(
    objective: Objective,
    predictor,
    eta,
    theta0,
    max_steps: int = 3,
    tolerance: float = 1.0 / 3.0,
    alpha: float = 0.05,
) -> FitResult:
    """Gauss-Newton from a point already near the minimum (a fit on a surrogate of this predictor):
    each step one evaluation with Jacobians, theta <- theta exp(delta) with delta = -(J^T J)^-1 J^T r
    in log theta; it stops when every |delta| is below ``tolerance`` times that parameter's eq. 6
    half-width (so the step left is well inside the bounds), reporting F and the Hessian of the
    last evaluation. For an expensive FE model where Levenberg-Marquardt would spend several
    evaluations confirming a minimum it already has."""
    eta = check_weights(eta)
    theta = np.asarray(theta0, float)
    t0 = time.perf_counter()
    history: list[tuple[list[float], float]] = []
    n, p = objective.data_points(eta), theta.size
    message = f"Gauss-Newton: {max_steps} steps without reaching the tolerance"
    seen: dict = {}
    for _ in range(max_steps):
        r, J = residuals_at(objective, predictor, eta, theta, keep=seen)
        history.append((theta.tolist(), float(r @ r)))
        delta, *_ = np.linalg.lstsq(J, -r, rcond=None)
        half = bounds_pct(2.0 * J.T @ J, s_from_data(float(r @ r), n, p, alpha)) / 100.0
        theta = theta * np.exp(delta)
        if np.all(np.abs(delta) <= tolerance * half):
            message = f"Gauss-Newton: last step {np.round(100 * delta, 3).tolist()} % within {tolerance:.2g} of the bounds"
            break
    # F, the Hessian and s of the last evaluation, at the stepped theta (first order)
    return _fit_result(
        objective,
        eta,
        theta,
        r=r,
        J=J,
        s=None,
        alpha=alpha,
        history=history,
        t0=t0,
        message=message,
        prediction=seen.get("prediction"),
    )


def _told(say: Callable[[str], None]) -> Callable[[int, np.ndarray, float], None]:
    """An FE fit's evaluations, one line each, for ``say``."""
    return lambda k, theta, F: say(f"  FE evaluation {k}: {np.round(theta, 4).tolist()}, F = {F:.4g}")
