"""How good a surrogate is, on points it was not trained on (issue: validation is part of the
deliverable): force relative error and displacement error relative to max |u| of each direction,
RMS and max; k-fold cross-validation on a campaign."""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
from sklearn.model_selection import KFold

from .base import FieldSurrogate, TrainingData
from .emulation_error import held_out_errors


def prediction_errors(surrogate: FieldSurrogate, data: TrainingData) -> dict[str, float]:
    """Errors of ``surrogate`` on ``data``, in percent.

    The force's relative error over every point and step; the displacement's error over every
    node and step divided by max |u| of that direction at that point. Steps whose force the
    campaign does not have (``data.missing``) are left out of the force errors.

    Runs at the perfect stick (over (c1, c5)) on a surrogate with mu are compared with its stick
    level (a multi-fidelity surrogate's ``stick_level()``).

    Parameters
    ----------
    surrogate : FieldSurrogate
        A trained surrogate (any Predictor).
    data : TrainingData
        The points and their responses.

    Returns
    -------
    dict
        ``points``, ``force_rms_pct``, ``force_max_pct``, ``displacement_rms_pct``,
        ``displacement_max_pct`` and ``ux_rms_pct``, ``uy_rms_pct``, ``uz_rms_pct``.

    Raises
    ------
    ValueError
        If the data are over other parameters than the surrogate's and it has no stick level for
        them.
    """
    if tuple(data.parameters) != tuple(surrogate.parameters):
        stick_level = getattr(surrogate, "stick_level", None)
        if stick_level is None or tuple(data.parameters) != tuple(
            surrogate.parameters[: len(data.parameters)]
        ):
            raise ValueError(
                f"the data are over {tuple(data.parameters)}, the surrogate over {tuple(surrogate.parameters)}; "
                "stick runs are compared only with a multi-fidelity surrogate's stick level"
            )
        surrogate = stick_level()  # a ValueError naming why where it has none
    pred = surrogate.predict(data.theta)
    rel_f = pred.force / data.force - 1.0
    if data.missing is not None:  # steps the campaign has no force for (filled for training)
        rel_f = rel_f[~data.missing]
    u_max = np.abs(data.displacement).max(axis=(1, 2))  # (n, 3)
    rel_u = (pred.displacement - data.displacement) / np.maximum(u_max, 1e-12)[:, None, None, :]
    return {
        "points": int(data.n),
        "force_rms_pct": 100.0 * float(np.sqrt(np.mean(rel_f**2))),
        "force_max_pct": 100.0 * float(np.abs(rel_f).max()),
        "displacement_rms_pct": 100.0 * float(np.sqrt(np.mean(rel_u**2))),
        "displacement_max_pct": 100.0 * float(np.abs(rel_u).max()),
        **{f"u{'xyz'[j]}_rms_pct": 100.0 * float(np.sqrt(np.mean(rel_u[..., j] ** 2))) for j in range(3)},
    }


def k_fold_errors(
    make,
    data: TrainingData,
    folds: int = 5,
    seed: int = 0,
    *,
    held_out: np.ndarray | None = None,
    say: Callable[[str], None] | None = None,
) -> dict[str, float]:
    """k-fold cross-validation of a surrogate: the held-out errors of all folds pooled.

    Parameters
    ----------
    make : callable
        ``make()`` returns an untrained surrogate.
    data : TrainingData
        The points to split.
    folds : int, default 5
        Number of folds, 2 <= folds <= points.
    seed : int, default 0
        Seed of the shuffle and of the training.
    held_out : numpy.ndarray, optional
        (points, steps + steps * nodes * 3), filled with each point's error vector from the model
        that did not see it (:func:`surrogate.emulation_error.held_out_errors`).
    say : callable, optional
        Told after each fold: its number, its held-out force RMS and the time so far.

    Returns
    -------
    dict
        ``folds``, ``points`` and the errors of :func:`prediction_errors` pooled (RMS over all
        held-out points, max over all).

    Raises
    ------
    ValueError
        If ``folds`` is not between 2 and the number of points.
    """
    if folds < 2 or folds > data.n:
        raise ValueError(f"k-fold needs 2 <= folds <= points ({data.n}), got {folds}")
    parts, t0 = [], time.perf_counter()
    for k, (train, test) in enumerate(KFold(folds, shuffle=True, random_state=seed).split(data.theta)):
        s = make().fit(data.subset(train), seed=seed)
        parts.append((prediction_errors(s, data.subset(test)), len(test)))
        if held_out is not None:
            held_out[test] = held_out_errors(s, data.subset(test))
        if say is not None:
            elapsed = time.perf_counter() - t0
            say(
                f"  fold {k + 1}/{folds}: {len(test)} held-out points, force RMS "
                f"{parts[-1][0].get('force_rms_pct', float('nan')):.3g} %  elapsed {elapsed:.0f} s, "
                f"eta {elapsed / (k + 1) * (folds - k - 1):.0f} s"
            )
    n = sum(k for _, k in parts)
    out = {"folds": folds, "points": n}
    for key in parts[0][0]:
        if key.endswith("rms_pct"):
            out[key] = float(np.sqrt(sum(e[key] ** 2 * k for e, k in parts) / n))
        elif key.endswith("max_pct"):
            out[key] = float(max(e[key] for e, _ in parts))
    return out
