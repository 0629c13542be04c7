"""The error budgets a surrogate or a fit carries: what a measured budget file leaves as a
systematic 95 % half-width for one model (:func:`remaining_bias`), the budgets shipped with the
studio (package data ``indentation_studio/error_budgets``) looked up by test and mesh
(:func:`shipped_budget`), and the one a surrogate recorded at training
(:func:`surrogate_error_budget`). Reading only: computing a budget (fits of a reference campaign)
is :mod:`indentation_studio.inference.budgets.error_budget`'s. Below both the surrogates and the fits, so
that training records a budget and a fit reads it without either importing the other."""

from __future__ import annotations

import json
from importlib.resources import files
from pathlib import Path

import numpy as np
from scipy.interpolate import LinearNDInterpolator
from scipy.spatial import QhullError

__all__ = [
    "budget_at",
    "budget_map",
    "indentation_test_of",
    "remaining_bias",
    "shipped_budget",
    "shipped_budgets_folder",
    "surrogate_error_budget",
]

#: Outside a budget's test points, the largest remaining bias of this many nearest points.
NEAREST_OUTSIDE = 3


def remaining_bias(budget_file, model: str) -> dict:
    """What an error budget leaves for ``model``: the systematic 95 % half-width a fit on it carries.

    The largest distance between truth and fit over the test points, in percent of the fit (as a
    fit's bounds are), and never less than in percent of the truth: max(|b|, |1 / (1 + b) - 1|)
    for a bias b. (A fit 18 % below the truth is 22 % of the fit away from it.) Where the rows
    carry the reference level's own uncertainty (``c1_reference_gci_pct``, a budget against a
    verification study's level, :func:`indentation_studio.inference.study_error_budget`), it is
    added at each point. Where they carry a correction (``c1_correction_pct``: a budget moved to a
    study's finest level, :func:`indentation_studio.inference.with_finest_reference`), a fit at a
    point is moved by it and its half-width is the reference's width; the largest value, held
    where no point is read, counts the correction as an error.

    Parameters
    ----------
    budget_file : str or pathlib.Path
        An ``error-budget.json`` (``inference.compute_error_budget``).
    model : str
        The model's name in the budget, e.g. the high-fidelity mesh preset.

    Returns
    -------
    dict
        ``c1_pct`` and ``c5_pct`` (percent, the largest over the points), ``points`` (each test
        point's ``c1``, ``c5`` and what it leaves, ``c1_pct`` and ``c5_pct``, with
        ``c1_correction_pct`` and ``c5_correction_pct`` in a corrected budget: what
        :func:`budget_at` interpolates) and ``source`` (the file, the model, the number of test
        points; a corrected budget's reference level and rule).

    Raises
    ------
    ValueError
        If the file is not an error budget, has no row of ``model``, or a bias that is not a number
        or not a fit (b <= -1).
    """
    try:
        payload = json.loads(Path(budget_file).read_text())
        rows = [row for row in payload["rows"] if row["model"] == model]
        names = sorted({row["model"] for row in payload["rows"]})
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"{budget_file}: not an error-budget.json ({exc})") from exc
    if not rows:
        raise ValueError(f"{budget_file}: no model {model!r} in it (it has {', '.join(names)})")
    left, each = {}, {}
    for name in ("c1", "c5"):
        try:
            b = np.array([row[f"{name}_bias_pct"] for row in rows], float) / 100.0
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"{budget_file}: {model!r} has no numeric {name}_bias_pct ({exc!r})") from exc
        if np.any(b <= -1.0) or not np.all(np.isfinite(b)):
            raise ValueError(f"{budget_file}: {model!r} has a bias of {name} that is not a fit")
        each[name] = 100.0 * np.maximum(np.abs(b), np.abs(1.0 / (1.0 + b) - 1.0))
        carried = [row.get(f"{name}_reference_gci_pct") for row in rows]
        if any(u is not None for u in carried):  # the reference level's own uncertainty (its GCI)
            u = np.array([np.nan if v is None else v for v in carried], float)
            if not np.all(np.isfinite(u) & (u >= 0)):
                raise ValueError(
                    f"{budget_file}: {model!r} has a reference GCI of {name} that is not a number >= 0"
                )
            each[name] = each[name] + u
        left[f"{name}_pct"] = float(np.max(each[name]))
    corrections = _corrections(rows, budget_file, model)
    if corrections is not None:  # held everywhere (no point read), the correction is a width again
        for j, name in enumerate(("c1", "c5")):
            left[f"{name}_pct"] = float(np.max(each[name] + np.abs(corrections[:, j])))
    try:
        left["points"] = [
            {"c1": float(row["c1_true"]), "c5": float(row["c5_true"]), "c1_pct": float(a), "c5_pct": float(b)}
            | (
                {}
                if corrections is None
                else {
                    "c1_correction_pct": float(corrections[i, 0]),
                    "c5_correction_pct": float(corrections[i, 1]),
                }
            )
            for i, (row, a, b) in enumerate(zip(rows, each["c1"], each["c5"], strict=True))
        ]
    except (KeyError, TypeError, ValueError):
        pass  # no test points recorded: the budget holds its largest value everywhere
    reference = payload.get("reference") if isinstance(payload.get("reference"), dict) else {}
    left["source"] = {
        "file": str(budget_file),
        "model": model,
        "points": len(rows),
        "reference_extrapolated": bool(reference.get("extrapolated", False)),
        "reference_gci_carried": bool(reference.get("gci_carried", False)),
    }
    if corrections is not None:
        left["source"] |= {
            "reference_level": reference.get("level"),
            "corrected_level": reference.get("corrected_level"),
            "rule": reference.get("rule"),
        }
    return left


def _corrections(rows: list[dict], budget_file, model: str) -> np.ndarray | None:
    """(points, 2) the rows' corrections of c1 and c5 (percent of the fit), or None: not corrected."""
    found = [row.get("c1_correction_pct") is not None for row in rows]
    if not any(found):
        return None
    try:
        out = np.array([[row["c1_correction_pct"], row["c5_correction_pct"]] for row in rows], float)
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(
            f"{budget_file}: {model!r} has a correction missing at some point ({exc!r})"
        ) from exc
    if not np.all(np.isfinite(out) & (out > -100.0)):
        raise ValueError(f"{budget_file}: {model!r} has a correction that is not a number above -100 %")
    return out


def budget_at(budget: dict | None, theta) -> dict | None:
    """What a budget leaves at the parameters ``theta``: interpolated between its test points.

    Only a budget measured against extrapolated values (its file's ``reference`` says
    ``"extrapolated": true``) or against a verification study's level with that level's GCI in
    its rows (``"gci_carried": true``) is interpolated. One
    measured against a single finer mesh keeps its largest value everywhere: that mesh's own error
    is not in its rows, and the largest value over the box is the margin that covers it
    (the shipped paper budget against 'reference', interpolated, would leave 11.9 % on c5 at
    {12, 299} kPa, where the demo's fit on 'default' of its example, made on 'fine' at c5 = 250,
    lies 20 % from the truth). Interpolated, inside
    the convex hull of the test points (in log c1, log c5, each scaled by the points'
    span) the remaining half-widths are interpolated linearly over the points' Delaunay
    triangles; outside it the largest of the :data:`NEAREST_OUTSIDE` nearest points' holds, and
    the source says so (``"verified": False``). A corrected budget's corrections are interpolated
    the same way; outside, the nearest point's holds and the spread of the nearest points'
    corrections joins the width. A budget without per-point values (one recorded before they were)
    or with too few points to triangulate keeps its largest value everywhere.

    Parameters
    ----------
    budget : dict or None
        As :func:`remaining_bias` (or a surrogate's recorded budget); None passes through.
    theta : array_like
        The fit's (c1, c5, ...) kPa; parameters beyond the first two (mu) are not in a budget.

    Returns
    -------
    dict or None
        The budget with ``c1_pct`` and ``c5_pct`` (and, corrected, ``c1_correction_pct`` and
        ``c5_correction_pct``) at ``theta`` and its ``source`` extended by
        ``at`` (c1, c5) and ``where``: ``"interpolated"``, ``"outside"`` (with ``nearest``, the
        points read) or ``"largest"`` (a reference that is one mesh, or no per-point values).

    Examples
    --------
    >>> from indentation_studio.surrogate import budget_at
    >>> source = {"model": "m", "points": 4, "reference_extrapolated": True}
    >>> b = {"c1_pct": 4.0, "c5_pct": 20.0, "source": source, "points": [
    ...     {"c1": c1, "c5": c5, "c1_pct": c1 / 5, "c5_pct": c5 / 27} for c1 in (5, 20) for c5 in (135, 540)]}
    >>> round(budget_at(b, [10.0, 270.0])["c5_pct"], 6), budget_at(b, [10.0, 270.0])["source"]["where"]
    (12.5, 'interpolated')
    >>> budget_at(b, [40.0, 270.0])["source"]["where"], budget_at(b, [40.0, 270.0])["c1_pct"]
    ('outside', 4.0)
    """
    if budget is None:
        return None
    source = budget.get("source")
    if source is not None and not isinstance(source, dict):
        return dict(budget)  # a budget given by hand, its source in words: its values hold everywhere
    out = dict(budget) | {"source": dict(source or {})}
    at = np.asarray(theta, float)[:2]
    out["source"]["at"] = at.tolist()
    points = budget.get("points") or []
    # a reference whose own error is in the rows (extrapolated values, or a level with its GCI)
    whole = out["source"].get("reference_extrapolated", False) or out["source"].get(
        "reference_gci_carried", False
    )
    xy = np.log([[p["c1"], p["c5"]] for p in points]) if whole and len(points) >= 3 else None
    if xy is None or np.any(np.ptp(xy, axis=0) <= 0) or not np.all(at > 0):
        out["source"]["where"] = "largest"  # one finer mesh's budget, or too few points to interpolate
        return out
    lo, span = xy.min(axis=0), np.ptp(xy, axis=0)
    xy, q = (xy - lo) / span, (np.log(at) - lo) / span
    corrected = all("c1_correction_pct" in p for p in points)
    names = ("c1_pct", "c5_pct") + (("c1_correction_pct", "c5_correction_pct") if corrected else ())
    values = np.array([[p[name] for name in names] for p in points], float)
    try:
        inside = LinearNDInterpolator(xy, values)(q[None, :])[0]
    except QhullError:  # the points on one line: no triangles
        inside = np.full(len(names), np.nan)
    if np.all(np.isfinite(inside)):
        out |= {name: float(v) for name, v in zip(names, inside, strict=True)}
        out["source"]["where"] = "interpolated"
        return out
    nearest = np.argsort(np.linalg.norm(xy - q, axis=1))[:NEAREST_OUTSIDE]
    widths = values[nearest, :2].max(axis=0)
    if corrected:  # the nearest point's correction; how much the nearest ones differ joins the width
        out["c1_correction_pct"], out["c5_correction_pct"] = (float(v) for v in values[nearest[0], 2:])
        widths = widths + np.ptp(values[nearest, 2:], axis=0)
    out["c1_pct"], out["c5_pct"] = (float(v) for v in widths)
    out["source"] |= {
        "where": "outside",
        "verified": False,
        "nearest": [[points[i]["c1"], points[i]["c5"]] for i in nearest],
    }
    return out


def shipped_budgets_folder() -> Path:
    """Where the shipped budgets are: ``indentation_studio/error_budgets`` (package data).

    Returns
    -------
    pathlib.Path
        The folder of the installed package's budget files.
    """
    return Path(str(files("indentation_studio") / "error_budgets"))


def indentation_test_of(model: dict) -> dict:
    """What makes two specs the same test for an error budget.

    Everything but the mesh, the solver's options and the parameters (c1, c5); the contact
    included (absent: the perfect stick), since a mesh's error measured with one contact is not
    that mesh's error with another.

    Parameters
    ----------
    model : dict
        A spec's ``to_dict()``.

    Returns
    -------
    dict
        Its geometry, indenter, protocol, contact and material less c1 and c5.
    """
    material = {k: v for k, v in (model.get("material") or {}).items() if k not in ("c1", "c5")}
    return {k: model.get(k) for k in ("geometry", "indenter", "protocol", "contact")} | {"material": material}


def shipped_budget(spec, folder: str | Path | None = None) -> dict | None:
    """What a shipped error budget leaves for ``spec``'s mesh (:func:`remaining_bias`), if one was measured.

    A budget counts when it is complete, was measured for the same test (geometry, indenter,
    protocol, contact, material but c1 and c5) and holds that mesh preset. A surrogate trained on such a
    campaign carries it in its fits' bounds.

    Parameters
    ----------
    spec : ModelSpec or dict
        The model (or its ``to_dict()``); a mesh without a preset has no budget.
    folder : str or pathlib.Path, optional
        Where to look; default :func:`shipped_budgets_folder`.

    Returns
    -------
    dict or None
        As :func:`remaining_bias`, its ``source`` also naming the reference mesh, the field of
        view (mm) and the weights; None when no budget fits.

    Examples
    --------
    >>> import indentation_studio as ins
    >>> left = ins.shipped_budget(ins.ModelSpec())
    >>> left["source"]["model"], left["c5_pct"] > 20
    ('default', True)
    >>> ins.shipped_budget(ins.ModelSpec().with_friction(0.3)) is None
    True
    """
    model = spec.to_dict() if hasattr(spec, "to_dict") else dict(spec)
    preset = (model.get("mesh") or {}).get("preset")
    if preset is None:
        return None
    test = json.loads(json.dumps(indentation_test_of(model)))
    for path in sorted(Path(folder or shipped_budgets_folder()).glob("*.json")):
        if path.name.startswith("field-error-"):  # the adequacy test's, not a budget
            continue
        try:
            payload = json.loads(path.read_text())
            reference = payload["reference"]["model"]
        except (OSError, ValueError, KeyError, TypeError):
            continue
        if json.loads(json.dumps(indentation_test_of(reference))) != test:
            continue
        if not payload.get("complete", True):
            continue
        try:
            left = remaining_bias(path, preset)
        except ValueError:
            continue
        left["source"] |= {
            "file": f"indentation_studio/error_budgets/{path.name}" if folder is None else str(path),
            "reference_mesh": (reference.get("mesh") or {}).get("preset"),
            "field_of_view_mm": payload.get("field_of_view_mm"),
            "weights": payload.get("weights"),
        }
        return left
    return None


def surrogate_error_budget(surrogate) -> dict | None:
    """The error budget a surrogate carries.

    Parameters
    ----------
    surrogate : FieldSurrogate
        Any object with a ``meta`` dict.

    Returns
    -------
    dict or None
        ``meta['error_budget']`` as recorded at training (None: none known then); for a surrogate
        without that record (an older file, or one being trained), the shipped budget for the FE
        model it emulates (``meta['campaign']['model']``, :func:`shipped_budget`).
    """
    meta = getattr(surrogate, "meta", {}) or {}
    if "error_budget" in meta:
        return meta["error_budget"]
    model = (meta.get("campaign") or {}).get("model")
    return shipped_budget(model) if model else None


def budget_map(budget: dict, c1, c5, *, noise_pct=None) -> dict:
    """A budget read over a grid of (c1, c5): its half-widths and where each value came from.

    Parameters
    ----------
    budget : dict
        As :func:`remaining_bias`.
    c1, c5 : array_like
        1-D grids, kPa.
    noise_pct : dict, optional
        ``{"c1": (points,), "c5": (points,)}``: a typical experiment's statistical half-width at the
        budget's points (the budget rows' ``<p>_half_width_pct``), interpolated the same way and
        combined with the budget's by root sum of squares in ``total_<p>_pct``.

    Returns
    -------
    dict
        ``c1``, ``c5`` (the grids), ``c1_pct``, ``c5_pct`` (len(c5), len(c1)), ``verified``
        (bool, same shape: inside the points' hull), ``points`` ((n, 2) kPa) and, with
        ``noise_pct``, ``total_c1_pct``, ``total_c5_pct``.
    """
    c1, c5 = np.asarray(c1, float), np.asarray(c5, float)
    shape = (len(c5), len(c1))
    out = {"c1": c1, "c5": c5, "c1_pct": np.empty(shape), "c5_pct": np.empty(shape)}
    out["verified"] = np.zeros(shape, bool)
    noise = None
    if noise_pct is not None:
        pts = [
            dict(p, c1_pct=a, c5_pct=b)
            for p, a, b in zip(budget["points"], noise_pct["c1"], noise_pct["c5"], strict=True)
        ]
        noise = dict(budget, points=pts)
        out["total_c1_pct"], out["total_c5_pct"] = np.empty(shape), np.empty(shape)
    for i, y in enumerate(c5):
        for j, x in enumerate(c1):
            at = budget_at(budget, [x, y])
            out["c1_pct"][i, j], out["c5_pct"][i, j] = at["c1_pct"], at["c5_pct"]
            out["verified"][i, j] = at["source"].get("where") == "interpolated"
            if noise is not None:
                n = budget_at(noise, [x, y])
                out["total_c1_pct"][i, j] = np.hypot(at["c1_pct"], n["c1_pct"])
                out["total_c5_pct"][i, j] = np.hypot(at["c5_pct"], n["c5_pct"])
    out["points"] = np.array([[p["c1"], p["c5"]] for p in budget.get("points") or []], float)
    return out
