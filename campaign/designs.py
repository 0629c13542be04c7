"""Parameter designs of a campaign: the paper's grid, user grids, CSV points, LHS and Sobol.

The paper (2.6) runs 775 simulations over c1 in [1, 21] kPa and c5 in [82.5, 578] kPa without
giving the spacing; 775 = 25 x 31, so :func:`paper_grid` takes 25 evenly spaced c1 values times
31 evenly spaced c5 values, ends included.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.stats import qmc

from .errors import DesignError

#: The paper's parameter box, kPa.
PAPER_BOUNDS: dict[str, tuple[float, float]] = {"c1": (1.0, 21.0), "c5": (82.5, 578.0)}
PAPER_COUNTS: dict[str, int] = {"c1": 25, "c5": 31}


@dataclass(frozen=True)
class Design:
    """Parameter points (n, p) with named columns and a description that reproduces them.

    Parameters
    ----------
    points : numpy.ndarray
        The points, shape (n, p), n >= 1; stored as a float array (kPa for c1 and c5).
    parameters : tuple of str
        The parameter of each column, e.g. ``("c1", "c5")``.
    description : str
        Text that reproduces the design (``"paper"``, ``"lhs:n=50:seed=0"``, ...).

    Raises
    ------
    DesignError
        If ``points`` is not (n >= 1, len(parameters)).
    """

    points: np.ndarray
    parameters: tuple[str, ...]
    description: str

    def __post_init__(self) -> None:
        pts = np.asarray(self.points, dtype=float)
        if pts.ndim != 2 or pts.shape[1] != len(self.parameters) or len(pts) == 0:
            raise DesignError(f"design {self.description!r}: points must be (n >= 1, {len(self.parameters)})")
        object.__setattr__(self, "points", pts)


def grid(
    bounds: dict[str, tuple[float, float]],
    counts: dict[str, int],
    description: str,
    log_axes: frozenset[str] = frozenset(),
) -> Design:
    """Full factorial grid, evenly spaced per parameter (ends included), first parameter slowest;
    the parameters in ``log_axes`` evenly spaced in log (a friction coefficient, whose effect
    fades as it grows: README, "Friction")."""
    names = tuple(bounds)
    axes = []
    for k in names:
        lo, hi = bounds[k]
        n = counts[k]
        if not (np.isfinite(lo) and np.isfinite(hi)) or n < 1 or (n > 1 and hi <= lo):
            raise DesignError(f"{k}: need finite LO < HI and N >= 1, got {lo}:{hi}:{n}")
        if k in log_axes and lo <= 0:
            raise DesignError(f"{k}: a log-spaced axis needs LO > 0, got {lo}:{hi}:{n}:log")
        spaced = np.geomspace if k in log_axes else np.linspace
        axes.append(spaced(lo, hi, n) if n > 1 else np.array([lo]))
    mesh = np.meshgrid(*axes, indexing="ij")
    return Design(np.column_stack([m.ravel() for m in mesh]), names, description)


def paper_grid() -> Design:
    """The paper's 775 points: 25 c1 x 31 c5 over its box (module docstring).

    Returns
    -------
    Design
        c1 evenly spaced over [1, 21] kPa (25 values) times c5 over [82.5, 578] kPa (31 values),
        ends included, c1 the slowest column; described as ``"paper"``.

    Examples
    --------
    >>> from indentation_studio.campaign import paper_grid
    >>> design = paper_grid()
    >>> design.points.shape, design.parameters
    ((775, 2), ('c1', 'c5'))
    """
    return grid(PAPER_BOUNDS, PAPER_COUNTS, "paper")


_RANGE = re.compile(r"^\s*(\w+)\s*=\s*([^:]+):([^:]+):(\d+)(:log)?\s*$")


def parse_grid(text: str) -> Design:
    """A grid from ``c1=LO:HI:N,c5=LO:HI:N`` (a third axis such as ``mu=0.25:4:5:log`` too; ``:log``
    spaces that axis evenly in log)."""
    bounds, counts, log_axes = {}, {}, set()
    for part in text.split(","):
        m = _RANGE.match(part)
        if not m:
            raise DesignError(f"grid part {part!r}: expected NAME=LO:HI:N[:log], e.g. c1=1:21:25")
        name = m.group(1)
        if name in bounds:
            raise DesignError(f"grid part {part!r}: {name} is given twice")
        try:
            bounds[name] = (float(m.group(2)), float(m.group(3)))
        except ValueError as exc:
            raise DesignError(f"grid part {part!r}: LO and HI must be numbers") from exc
        counts[name] = int(m.group(4))
        if m.group(5):
            log_axes.add(name)
    # the parameters in the model's order (c1, c5, then mu), whatever the order written: a
    # surrogate's parameters are its campaign's, and the fits read theta as (c1, c5, mu)
    order = sorted(bounds, key=lambda k: _CANONICAL.index(k) if k in _CANONICAL else len(_CANONICAL))
    bounds = {k: bounds[k] for k in order}
    return grid(bounds, counts, text.replace(" ", ""), frozenset(log_axes))


_CANONICAL = ("c1", "c5", "mu")
_BOX_RANGE = re.compile(r"^\s*(\w+)\s*=\s*([^:]+):([^:]+)(:log)?\s*$")


def points_from_csv(path: str | Path, parameters: tuple[str, ...] = ("c1", "c5")) -> Design:
    """Points from a CSV file with a header naming the parameter columns (other columns ignored)."""
    import pandas as pd

    path = Path(path)
    try:
        table = pd.read_csv(path)
    except (OSError, ValueError) as exc:
        raise DesignError(f"{path}: cannot read the points CSV ({exc})") from exc
    missing = [k for k in parameters if k not in table.columns]
    if missing:
        raise DesignError(f"{path}: missing column(s) {missing}; the header must name {list(parameters)}")
    values = table[list(parameters)].apply(pd.to_numeric, errors="coerce")
    bad = values.isna().any(axis=1)
    if bad.any():
        row = int(np.argmax(bad.to_numpy()))
        col = next(k for k in parameters if pd.isna(values.iloc[row][k]))
        raise DesignError(f"{path}: row {row + 2}, column {col!r}: not a number ({table.iloc[row][col]!r})")
    return Design(values.to_numpy(float), tuple(parameters), f"csv:{path}")


def space_filling(
    kind: str,
    n: int,
    bounds: dict[str, tuple[float, float]] | None = None,
    seed: int = 0,
    *,
    log_axes: frozenset[str] = frozenset(),
) -> Design:
    """A Latin hypercube (``lhs``) or scrambled Sobol (``sobol``) design of ``n`` points.

    The points come from scipy.stats.qmc, scaled into ``bounds``, and are reproducible from
    ``seed``. An axis in ``log_axes`` is filled evenly in log: a friction coefficient over 0.1 to
    3 then gets two thirds of its points below 1, where slip changes the response (README,
    "Friction"; above about 1 nothing slips and the response is the stick's).

    Parameters
    ----------
    kind : {"lhs", "sobol"}
        The space-filling design.
    n : int
        Number of points (>= 1).
    bounds : dict of str to (float, float), optional
        Parameter -> (low, high), kPa; default the paper's box (c1 in [1, 21], c5 in [82.5, 578]).
    seed : int, default 0
        Seed of the generator.
    log_axes : frozenset of str, optional
        Parameters filled evenly in log (their LO must be > 0).

    Returns
    -------
    Design
        The points, described as ``"<kind>:n=<n>:seed=<seed>"`` (with the bounds that differ from
        the paper's box after a comma, as :func:`design_from_option` reads them).

    Raises
    ------
    DesignError
        If ``n < 1``, ``kind`` is neither ``lhs`` nor ``sobol``, or a log axis has LO <= 0.

    Examples
    --------
    >>> from indentation_studio.campaign import space_filling
    >>> space_filling("lhs", 8, seed=1).points.shape
    (8, 2)
    """
    bounds = bounds or PAPER_BOUNDS
    d = len(bounds)
    if n < 1:
        raise DesignError(f"{kind}: need n >= 1 points, got {n}")
    if kind == "lhs":
        unit = qmc.LatinHypercube(d=d, seed=seed).random(n)
    elif kind == "sobol":
        unit = qmc.Sobol(d=d, scramble=True, seed=seed).random(n)
    else:
        raise DesignError(f"unknown design kind {kind!r}; use 'lhs' or 'sobol'")
    lo, hi = np.array(list(bounds.values()), dtype=float).T
    logged = np.array([k in log_axes for k in bounds])
    if np.any(lo[logged] <= 0):
        raise DesignError(f"{kind}: a log-filled axis needs LO > 0, got {dict(bounds)}")
    lo[logged], hi[logged] = np.log(lo[logged]), np.log(hi[logged])
    points = qmc.scale(unit, lo, hi)
    points[:, logged] = np.exp(points[:, logged])
    extra = [
        f"{k}={a:g}:{b:g}" + (":log" if k in log_axes else "")
        for k, (a, b) in bounds.items()
        if PAPER_BOUNDS.get(k) != (a, b) or k in log_axes
    ]
    return Design(points, tuple(bounds), ",".join([f"{kind}:n={n}:seed={seed}", *extra]))


def design_from_option(text: str) -> Design:
    """The design a ``--grid`` option of the CLI names.

    Parameters
    ----------
    text : str
        ``paper`` (:func:`paper_grid`), a CSV path (one column per parameter), a grid
        ``c1=LO:HI:N,c5=LO:HI:N``, or ``lhs:N[:SEED]`` / ``sobol:N[:SEED]`` over the paper's box
        (:func:`space_filling`), after which ``,NAME=LO:HI[:log]`` parts change a range or add
        an axis (``sobol:512:1,mu=0.1:3:log``: friction filled evenly in log).

    Returns
    -------
    Design
        The points it names.

    Raises
    ------
    DesignError
        If the text cannot be read as one of these forms (or the points are invalid).

    Examples
    --------
    >>> from indentation_studio.campaign import design_from_option
    >>> design_from_option("c1=1:21:3,c5=82.5:578:2").points.shape
    (6, 2)
    >>> design_from_option("sobol:8:1,mu=0.1:3:log").parameters
    ('c1', 'c5', 'mu')
    """
    t = text.strip()
    if t == "paper":
        return paper_grid()
    kind = t.split(":", 1)[0]
    if kind in ("lhs", "sobol"):
        head, *ranges = t.split(",")
        parts = head.split(":")
        try:
            n = int(parts[1])
            seed = int(parts[2]) if len(parts) > 2 else 0
        except (IndexError, ValueError) as exc:
            raise DesignError(f"--grid {t!r}: expected {kind}:N or {kind}:N:SEED") from exc
        bounds, log_axes = dict(PAPER_BOUNDS), set()
        for part in ranges:
            m = _BOX_RANGE.match(part)
            if not m:
                raise DesignError(f"--grid part {part!r}: expected NAME=LO:HI[:log], e.g. mu=0.1:3:log")
            try:
                bounds[m.group(1)] = (float(m.group(2)), float(m.group(3)))
            except ValueError as exc:
                raise DesignError(f"--grid part {part!r}: LO and HI must be numbers") from exc
            if not bounds[m.group(1)][0] < bounds[m.group(1)][1]:
                raise DesignError(f"--grid part {part!r}: need LO < HI")
            if m.group(4):
                log_axes.add(m.group(1))
        order = sorted(bounds, key=lambda k: _CANONICAL.index(k) if k in _CANONICAL else len(_CANONICAL))
        bounds = {k: bounds[k] for k in order}
        return space_filling(kind, n, bounds, seed, log_axes=frozenset(log_axes))
    if t.lower().endswith(".csv"):
        return points_from_csv(t)
    return parse_grid(t)
