"""Units of imported lab files: the factors to the studio's mm, mN and s, and the unit a column
header states (``coor.X [mm]``, ``Force (N)``, ``time_s``).

An importer never guesses a unit: it takes the one the caller gives or the one the header states,
and refuses a column that has neither, or whose header contradicts the caller.
"""

from __future__ import annotations

import re

from ..experiment.data import ExperimentDataError

#: factor to millimetres
LENGTH_MM = {"m": 1e3, "cm": 10.0, "mm": 1.0, "um": 1e-3, "µm": 1e-3, "micron": 1e-3, "in": 25.4}
#: factor to millinewtons (gram-force: a balance scale reads grams, as in paper 2.7)
FORCE_MN = {
    "kn": 1e6,
    "n": 1e3,
    "mn": 1.0,
    "un": 1e-3,
    "µn": 1e-3,
    "g": 9.80665,
    "gf": 9.80665,
    "kg": 9806.65,
    "kgf": 9806.65,
    "lbf": 4448.2216152605,
}
#: factor to seconds
TIME_S = {"s": 1.0, "sec": 1.0, "ms": 1e-3, "min": 60.0, "h": 3600.0}

_KINDS = {"length": LENGTH_MM, "force": FORCE_MN, "time": TIME_S}
_HEADER_UNIT = re.compile(r"[\[(]\s*([^\])]*?)\s*[\])]\s*$")
_SUFFIX_UNIT = re.compile(r"_([A-Za-zµ]+)$")


def unit_factor(unit: str, kind: str, where: str = "") -> float:
    """The factor that takes a value in ``unit`` to the studio's unit of ``kind`` (length: mm,
    force: mN, time: s). ``where`` names the file or column for the error."""
    table = _KINDS[kind]
    key = unit.strip().lower()
    if key not in table:
        raise ExperimentDataError(
            f"{where}: unknown {kind} unit {unit!r} (known: {', '.join(sorted(set(table)))})"
        )
    return table[key]


def header_unit(header: str) -> str | None:
    """The unit a column header states: ``coor.X [mm]`` -> ``mm``, ``Force (N)`` -> ``N``,
    ``time_s`` -> ``s``; None when it states none (``[-]`` and ``[ ]`` state none)."""
    match = _HEADER_UNIT.search(header)
    if match:
        unit = match.group(1).strip()
        return unit if unit and unit not in ("-", "#") else None
    match = _SUFFIX_UNIT.search(header.strip())
    if match and any(match.group(1).lower() in {k.lower() for k in t} for t in _KINDS.values()):
        return match.group(1)
    return None


def resolve_unit(header: str, given: str | None, kind: str, where: str) -> float:
    """The factor to the studio's unit for a column: from ``given`` or the header, which must agree
    when both are there; an error naming the file and column when neither says."""
    stated = header_unit(header)
    if given is not None and stated is not None:
        if unit_factor(given, kind, where) != unit_factor(stated, kind, where):
            raise ExperimentDataError(
                f"{where}: column '{header}' states {stated!r} but {given!r} was declared for it"
            )
    unit = given if given is not None else stated
    if unit is None:
        raise ExperimentDataError(
            f"{where}: column '{header}' states no unit; declare the {kind} unit (e.g. "
            f"{'mm' if kind == 'length' else 'mN' if kind == 'force' else 's'})"
        )
    return unit_factor(unit, kind, f"{where}, column '{header}'")
