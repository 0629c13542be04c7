"""The mesh's error with the fit's own free parameters (issue 57, option (i)).

An error budget is measured by fitting the reference's data with the fit's model, mu held (the
stick). A plain fit frees mu, and mu takes up the part of the mesh's error that looks like slip:
measured on contact-L4 experiments, level 3's first-order move in c5 was -6.4 % with mu held and
-10.1 % with mu free at R = 8 mm, {1.5, 560} kPa, and -4.3 % against -7.9 % at R = 4.77 mm,
{3, 540} (docs/validation/model-error.md, "The mesh's move with mu free").

Here each of the budget's points' output differences d (level 3 less level 4, force and top
field, :class:`surrogate.mesh_differences.MeshDifferences`) is carried through the fit at its own
theta: the fit is made again on the surrogate with its data moved by d (what level 3 would have
recorded there), once with mu free and once with mu held at the fit's, and the mesh's move is the
fit less that refit. What freeing mu adds, m = move(mu free) - move(mu held) over (c1, c5), is read
at the fit as the budget is (interpolated inside its points' hull, the nearest points' outside:
:func:`surrogate.error_budgets.budget_at`). The budget's correction is moved by -m and its
half-width grows by |m|: the bound holds both the mu-held budget and twice the freed move.

The refits are nonlinear because mu's move is: on a `contact-L4` record at R = 4.77 mm, {11, 540}
kPa with the stick, the plain fit took mu = 0.45 and c5 3.6 % below the plain fit of level 3's
record of the same point and noise (mu = 1.89), where a first-order move at the fit (one
Gauss-Newton step) gave 0.3 % (docs/validation/model-error.md, "The freed move made again by
refits")."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.optimize import least_squares

from ...design.friction_treatment import FixedParameter
from ...design.objective import Objective, check_weights
from ...forward.predictor import Prediction
from ...surrogate.error_budgets import budget_at
from ...surrogate.mesh_differences import MeshDifferences
from .fit_moves import moved_prediction
from .model_error_parts import ModelError

__all__ = [
    "MovedOutputs",
    "freed_mu_moves",
    "mesh_moves",
    "points_read",
    "with_freed_mu",
]

#: Evaluations of the objective each refit may take at most (scipy least_squares' max_nfev).
REFIT_EVALUATIONS = 60


class MovedOutputs:
    """A predictor whose outputs are moved by one fixed output-space change (log force, field).

    Parameters
    ----------
    predictor : Predictor
        The predictor moved.
    change : numpy.ndarray
        (steps + steps * nodes * 3,) the change of log force per step, then of the field (mm).
    """

    def __init__(self, predictor, change: np.ndarray) -> None:
        self.predictor = predictor
        self.parameters = tuple(predictor.parameters)
        self.change = np.asarray(change, float)

    def predict(self, theta, jacobian: bool = False) -> Prediction:
        """The moved predictor's response (its Jacobians are the predictor's, the force's scaled).

        Parameters
        ----------
        theta : array_like
            (n, p) the parameters.
        jacobian : bool, default False
            Also the Jacobians.

        Returns
        -------
        Prediction
        """
        pred = self.predictor.predict(theta, jacobian=jacobian)
        steps = pred.force.shape[1]
        return moved_prediction(pred, self.change[:steps], self.change[steps:])


def _refit(objective: Objective, eta: np.ndarray, predictor, theta: np.ndarray, box) -> np.ndarray:
    """log theta of the fit of ``objective`` on ``predictor`` from ``theta``, kept inside ``box``."""
    return _refit_with_cost(objective, eta, predictor, theta, box)[0]


def _refit_with_cost(
    objective: Objective, eta: np.ndarray, predictor, theta: np.ndarray, box
) -> tuple[np.ndarray, float]:
    """:func:`_refit` and its least-squares cost."""
    z_lo, z_hi = np.log(box[0]), np.log(box[1])

    def residuals(z: np.ndarray) -> np.ndarray:
        return objective.residuals(predictor.predict(np.exp(z)[None]), eta)[0]

    def jacobian(z: np.ndarray) -> np.ndarray:
        t = np.exp(z)
        return objective.jacobian(predictor.predict(t[None], jacobian=True), eta)[0] * t

    z0 = np.clip(np.log(theta), z_lo, z_hi)
    sol = least_squares(
        residuals, z0, jac=jacobian, bounds=(z_lo, z_hi), method="trf", max_nfev=REFIT_EVALUATIONS
    )
    return sol.x, float(sol.cost)


def _fit_with_mu(theta) -> np.ndarray:
    theta = np.asarray(theta, float)
    if theta.shape != (3,):
        raise ValueError(
            f"freeing mu needs the fit's (c1, c5, mu), got {theta.size} values (shape {theta.shape})"
        )
    return theta


def freed_mu_moves(
    objective: Objective,
    eta,
    surrogate,
    theta: np.ndarray,
    differences: MeshDifferences,
    *,
    only: np.ndarray | None = None,
    with_mu: bool = False,
) -> np.ndarray:
    """What freeing mu adds to each point's mesh error in the fit at ``theta`` (refits).

    Each point's output change d (level 3 less level 4 at the surrogate's nodes) moves the fit by
    log theta_hat - log theta_refit, where the refit fits the surrogate to the data moved by d (the
    surrogate's outputs moved by -d), from ``theta``, inside the surrogate's box: over (c1, c5, mu)
    with mu free, over (c1, c5) with mu held at the fit's.

    Parameters
    ----------
    objective : Objective
        The fit's objective (its target the fit's data).
    eta : array_like
        The weights of eq. 5.
    surrogate : FieldSurrogate
        The fit's surrogate, trained with mu (its parameters c1, c5, mu; ``scaler.lo``, ``scaler.hi``
        its box).
    theta : numpy.ndarray
        (3,) the fit (c1, c5 kPa, mu).
    differences : MeshDifferences
        The budget's points' output differences.
    only : numpy.ndarray of bool, optional
        (n,) the points to move (the others' rows are NaN); default all.
    with_mu : bool, default False
        Also mu's own move with mu free, a third column (log mu; held, it does not move).

    Returns
    -------
    numpy.ndarray
        (n, 2) move(mu free) - move(mu held) in log c1, log c5 at each point ((n, 3) with
        ``with_mu``).

    Raises
    ------
    ValueError
        If ``theta`` is not (c1, c5, mu).
    """
    theta = _fit_with_mu(theta)
    changes = differences.outputs_at(surrogate.top_xyz)
    moves = np.full((len(changes), 3 if with_mu else 2), np.nan)
    for k in np.flatnonzero(np.ones(len(changes), bool) if only is None else only):
        free, held = mesh_moves(objective, eta, surrogate, theta, changes[k], with_mu=with_mu)
        moves[k, :2] = free[:2] - held
        if with_mu:
            moves[k, 2] = free[2]
    return moves


def mesh_moves(
    objective: Objective, eta, surrogate, theta: np.ndarray, change: np.ndarray, *, with_mu: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """How one output change d moves the fit at ``theta``, with mu free and with mu held (refits).

    The move is log theta_hat - log theta_refit over (c1, c5), the refit fitting the surrogate to
    the data moved by d (its outputs moved by -d) from ``theta``, inside the surrogate's box.

    Parameters
    ----------
    objective : Objective
        The fit's objective (its target the fit's data).
    eta : array_like
        The weights of eq. 5.
    surrogate : FieldSurrogate
        The fit's surrogate over (c1, c5, mu).
    theta : numpy.ndarray
        (3,) the fit (c1, c5 kPa, mu).
    change : numpy.ndarray
        (steps + steps * nodes * 3,) d: log force per step, then the field (mm).
    with_mu : bool, default False
        Also mu's own move with mu free (log mu_hat - log mu_refit), the free move's third value:
        the refit with the lowest cost of those started at the fit and at mu's range ends
        ((c1, c5) the fit's), because mu's objective has more than one valley. On stick data made on
        contact-L4 a surrogate with friction fitted mu = 0.32, where the level-3 stick the budget's
        differences lead back to lies at the range's end; a refit from the fit alone moved mu by
        1.4 % (session 35).

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        (2,) the move with mu free ((3,) with ``with_mu``) and (2,) with mu held, in log c1, log c5
        (and log mu).

    Raises
    ------
    ValueError
        If ``theta`` is not (c1, c5, mu) or ``change`` is not one output vector of the surrogate.
    """
    theta = _fit_with_mu(theta)
    change = np.asarray(change, float)
    if change.ndim != 1:
        raise ValueError(f"one output change d is one vector, got the shape {change.shape}")
    e = check_weights(eta)
    box = np.asarray(surrogate.scaler.lo, float), np.asarray(surrogate.scaler.hi, float)
    mu = float(np.clip(theta[2], box[0][2], box[1][2]))
    moved = MovedOutputs(surrogate, -np.asarray(change, float))
    z = np.log(np.append(theta[:2], mu))
    refit, cost = _refit_with_cost(objective, e, moved, theta, box)
    free = z - refit
    held = z[:2] - _refit(objective, e, FixedParameter(moved, "mu", mu), theta[:2], (box[0][:2], box[1][:2]))
    if not with_mu:
        return free[:2], held
    mu_move = free[2]
    for end in (box[0][2], box[1][2]):  # mu's other valleys: the lowest cost's mu
        other, other_cost = _refit_with_cost(objective, e, moved, np.append(theta[:2], end), box)
        if other_cost < cost:
            mu_move, cost = z[2] - other[2], other_cost
    return np.append(free[:2], mu_move), held


def points_read(points: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Which of a budget's points :func:`surrogate.error_budgets.budget_at` reads at ``theta``.

    Inside their hull the vertices of the triangle holding ``theta`` (a weight above zero), outside
    the nearest ones; where it cannot read between them (fewer than three points), all.

    Parameters
    ----------
    points : numpy.ndarray
        (n, 2) the points' (c1, c5), kPa.
    theta : numpy.ndarray
        The fit's (c1, c5, ...).

    Returns
    -------
    numpy.ndarray of bool
        (n,)
    """
    read = np.zeros(len(points), bool)
    for k in range(len(points)):
        one = [
            {"c1": float(c1), "c5": float(c5), "c1_pct": float(j == k), "c5_pct": 0.0}
            for j, (c1, c5) in enumerate(points)
        ]
        at = budget_at({"source": {"reference_gci_carried": True}, "points": one}, theta)
        if "c1_pct" not in at:  # too few points to read between: the largest of all is taken
            return np.ones(len(points), bool)
        read[k] = at["c1_pct"] > 0.0
    return read


def with_freed_mu(
    model: ModelError, objective: Objective, eta, surrogate, theta: np.ndarray, differences: MeshDifferences
) -> ModelError:
    """``model`` with what freeing mu adds to the mesh's error (:func:`freed_mu_moves`).

    The moves are read at the fit as the budget is (``budget_at``: interpolated inside the points'
    hull; outside, the nearest point's move and the largest of the nearest ones' plus their spread);
    the correction is moved by -d and the budget's half-width grows by |d| (percent of the fit). Its
    source records the added correction and width (``budget_source['mu_free']``), and the mesh's
    move on mu itself, the largest over the points read (``mu_pct``, percent of mu: a part of mu's
    model error, :func:`inference.fit.error_parts.mu_model_error_pct`; on stick data a fit that
    takes the mesh's error for slip moves mu across its range).

    Parameters
    ----------
    model : ModelError
        The parts over (c1, c5), mu held.
    objective, eta, surrogate, theta, differences
        As :func:`freed_mu_moves`.

    Returns
    -------
    ModelError
    """
    read = points_read(differences.points, theta)
    moves = freed_mu_moves(objective, eta, surrogate, theta, differences, only=read, with_mu=True)
    # the mesh's move on mu itself, the largest of those read, as the larger side of a move in log
    # (mu 0.32 -> 3: +830 %, where the move's own expm1 says -89 %)
    mu_pct = float(100.0 * np.expm1(np.abs(moves[read, 2]).max())) if read.any() else 0.0
    d = 100.0 * np.expm1(moves[:, :2])
    d[~read] = 0.0  # (n, 2) percent; the points the budget does not read at theta weigh nothing
    points = [
        {
            "c1": float(c1),
            "c5": float(c5),
            "c1_pct": abs(a),
            "c5_pct": abs(b),
            "c1_correction_pct": -a,
            "c5_correction_pct": -b,
        }
        for (c1, c5), (a, b) in zip(differences.points, d.tolist(), strict=True)
    ]
    at = budget_at({"source": {"reference_gci_carried": True}, "points": points}, theta)
    if "c1_pct" in at:
        add_width = np.array([at["c1_pct"], at["c5_pct"]])
        add_correction = np.array([at["c1_correction_pct"], at["c5_correction_pct"]])
    else:  # too few points to read between: the largest move widens, nothing is corrected
        add_width, add_correction = np.abs(d).max(axis=0), np.zeros(2)
    source = dict(model.budget_source or {}) | {
        "mu_free": {
            "c1_pct": float(add_width[0]),
            "c5_pct": float(add_width[1]),
            "c1_correction_pct": float(add_correction[0]),
            "c5_correction_pct": float(add_correction[1]),
            "mu_pct": mu_pct,
            "where": at["source"]["where"],
            "file": differences.meta.get("file"),
            "points": len(points),
            "rule": "each budget point's level-3 less level-4 outputs moved through the fit by refits with mu "
            "free and held; the budget's correction moved by what freeing mu adds, its width grown by as much",
        }
    }
    budget = np.asarray(model.budget_pct, float).copy()
    budget[:2] = budget[:2] + add_width
    correction = (
        np.zeros(len(budget)) if model.correction_pct is None else np.array(model.correction_pct, float)
    )
    correction[:2] = correction[:2] + add_correction
    return replace(model, budget_pct=budget, correction_pct=correction, budget_source=source)
