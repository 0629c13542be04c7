"""What a fit says of mu, in one sentence: the fit command's printout and the demo's report say it
in the same words (fit.json's ``friction`` record)."""

from __future__ import annotations

from .. import inference

__all__ = ["mu_statement"]


def mu_statement(friction: dict | None) -> str:
    """The fit's mu in one sentence of plain text, or "" where the fit has no mu.

    Not identified where its 95 % interval is its whole range or reaches the range's end (with the
    model's own error on mu counted, fit.json's ``mu_identified``); else its value and interval.
    The interval's parts (statistical, model) and the range's ends the data do not bound are said
    where the record has them.

    Parameters
    ----------
    friction : dict or None
        fit.json's ``friction`` (:meth:`inference.ExperimentFit.to_dict`).

    Returns
    -------
    str

    Examples
    --------
    >>> mu_statement({"mu": 0.5, "mu_interval": [0.41, 0.62], "mu_identified": True})
    'mu = 0.5, 95 % within [0.41, 0.62]'
    >>> mu_statement({"mu": 1.58, "mu_interval": [0.1004, 2.996], "mu_identified": False})
    "mu is not identified by these data: its 95 % interval [0.1, 3] reaches its range's end (the fit at 1.58)"
    """
    if not friction or friction.get("mu") is None:
        return ""
    mu = friction["mu"]
    lo, hi = friction.get("mu_interval") or friction.get("mu_range") or (float("nan"), float("nan"))
    at_limit = friction.get("mu_at_limit")
    limit = f" (on its range's {at_limit} limit)" if at_limit else ""
    ends = [side for side, reached in (friction.get("mu_reaches_range_end") or {}).items() if reached]
    open_ = (
        f"; the data, with the model's own errors on mu, do not bound it at the range's {' and '.join(ends)} end"
        if ends
        else ""
    )
    statistical, model = friction.get("mu_statistical_pct"), friction.get("mu_model_pct")
    parts = (
        f" (statistical +- {statistical:.3g} %, model +- {model:.3g} %)"
        if statistical is not None and model is not None
        else ""
    )
    mu_range = friction.get("mu_range")
    if mu_range is not None and inference.interval_is_whole_range((lo, hi), mu_range):
        return (
            f"mu is not identified by these data: its 95 % interval{parts} is its whole range"
            f" [{lo:.3g}, {hi:.3g}] (the fit at {mu:.3g}{limit})"
        )
    if not friction.get("mu_identified"):
        return (
            f"mu is not identified by these data: its 95 % interval{parts} [{lo:.3g}, {hi:.3g}] reaches "
            f"its range's end (the fit at {mu:.3g}{limit}{open_})"
        )
    return f"mu = {mu:.3g}{limit}, 95 % within [{lo:.3g}, {hi:.3g}]{parts}{open_}"
