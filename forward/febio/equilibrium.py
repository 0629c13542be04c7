"""Equilibrium check of FEBio's converged steps: the indenter's reaction against the bottom's.

In the quarter model the only supports in z are the bottom nodes, so at equilibrium the rigid
indenter's vertical reaction (``-Fz`` of the ``indenter`` data record) equals the sum of the
bottom nodes' reactions (``Rz`` of ``bottom_reaction``). FEBio's convergence norms (energy and
displacement relative to the increment's first iteration, no residual norm by default) sometimes
accept a state that is not in equilibrium; its reported indenter force is then wrong, by under
1 % (the baseline at 12.5 mm) or by orders of magnitude (5.9e5 mN at 5.0 mm where the
neighbouring steps gave about 3,200 mN). Such a step is flagged and its force replaced by NaN,
so that no force the studio uses comes from it.

The tolerance, :class:`EquilibriumTolerance` (defaults in :data:`DEFAULT_EQUILIBRIUM_TOLERANCE`),
and why it is what it is, using the FEBio baseline run the tests check against (README, "FEBio backend"):

- ``relative = 3e-3`` (0.3 % of the bottom reaction). Clean steps of that run balance to under
  4e-5, 75 times less, so FEBio's ordinary convergence never trips it. A flagged step's force is
  off by about its imbalance; 0.3 % is what two clean FEBio runs of the same model differ by
  (skyline vs PARDISO: within 0.33 %), so an imbalance below it is inside FEBio's own
  reproducibility and an imbalance above it is an error of FEBio's acceptance, not of the model.
  At 12.5 mm the baseline's imbalance is -0.85 %: the indenter force lies 0.90 % below a cubic
  through the neighbouring steps while the bottom reaction lies 0.05 % from it (quarter model:
  the indenter force rises 148 mN into the step and 205 mN out of it, the bottom reaction 174
  and 179 mN), so the step is flagged. At 11.5 mm it is -0.09 %, and both reactions lie above
  that cubic alike (0.18 % and 0.26 %: the curve's roughness from FEBio's facet contact, shared
  by both): the step is kept.
- ``absolute_mN = 0.01`` (whole specimen): an imbalance under 10 micronewtons is accepted whatever
  the force, far below what the paper's load cell (Interface WMC-50, 50 lbf = 222 N full scale)
  resolves. It matters only at depth 0 (both reactions 0) and at the first step of very soft
  materials.

The balance alone suffices for the failure seen (the indenter's reaction jumps while the bottom
stays consistent); a jump test against neighbouring steps was not added: it would misfire where
the force rises steeply at contact onset, and an equilibrium state cannot carry a force that the
bottom does not carry too. A result without bottom reactions (a log not written by
:func:`forward.febio.writer.write_feb`) is marked unchecked instead.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..result import SYMMETRY_FACTOR, SimulationResult

#: Keys of ``SimulationResult.convergence`` used by the check (quarter-model values, mN).
BOTTOM_KEY = "bottom_reaction_quarter"
INDENTER_KEY = "indenter_reaction_quarter"  # -Fz as FEBio reported it, before any NaN
IMBALANCE_KEY = "equilibrium_imbalance"


@dataclass(frozen=True)
class EquilibriumTolerance:
    """When a FEBio step counts as off equilibrium (see the module docstring for the values).

    A step is flagged when ``|F - R| > max(relative * |R|, absolute_mN)``, with F the indenter's
    reaction and R the sum of the bottom reactions, both of the whole specimen (4 x quarter), or
    when F is not finite.
    """

    relative: float = 3e-3
    absolute_mN: float = 0.01

    def __post_init__(self) -> None:
        if not (np.isfinite(self.relative) and self.relative > 0):
            raise ValueError(f"EquilibriumTolerance.relative must be > 0, got {self.relative!r}")
        if not (np.isfinite(self.absolute_mN) and self.absolute_mN >= 0):
            raise ValueError(f"EquilibriumTolerance.absolute_mN must be >= 0, got {self.absolute_mN!r}")


DEFAULT_EQUILIBRIUM_TOLERANCE = EquilibriumTolerance()


def relative_imbalance(indenter_force: np.ndarray, bottom_reaction: np.ndarray, floor: float) -> np.ndarray:
    """(F - R) / max(|R|, floor) per step: the indenter's excess over the bottom reaction, relative
    to the bottom reaction (``floor`` in the forces' unit keeps depth 0, where both are 0, at 0)."""
    f = np.asarray(indenter_force, float)
    r = np.asarray(bottom_reaction, float)
    return (f - r) / np.maximum(np.abs(r), max(floor, np.finfo(float).tiny))


def off_equilibrium_steps(
    indenter_force: np.ndarray,
    bottom_reaction: np.ndarray,
    tolerance: EquilibriumTolerance = DEFAULT_EQUILIBRIUM_TOLERANCE,
) -> np.ndarray:
    """Which steps are off equilibrium (bool per step); forces of the whole specimen, mN."""
    f = np.asarray(indenter_force, float)
    r = np.asarray(bottom_reaction, float)
    if f.shape != r.shape:
        raise ValueError(f"indenter force {f.shape} and bottom reaction {r.shape} differ in shape")
    allowed = np.maximum(tolerance.relative * np.abs(r), tolerance.absolute_mN)
    with np.errstate(invalid="ignore"):
        return ~np.isfinite(f) | ~np.isfinite(r) | (np.abs(f - r) > allowed)


def check_equilibrium(
    result: SimulationResult, tolerance: EquilibriumTolerance = DEFAULT_EQUILIBRIUM_TOLERANCE
) -> SimulationResult:
    """``result`` with its off-equilibrium steps flagged and their forces NaN.

    Reads the indenter's reaction from ``convergence['indenter_reaction_quarter']`` (or, the
    first time, from the force) and the bottom's from ``convergence['bottom_reaction_quarter']``;
    writes ``off_equilibrium``, ``convergence['equilibrium_imbalance']`` and
    ``solver['equilibrium']``. Running it again (another tolerance) starts from FEBio's numbers.
    Without bottom reactions the result comes back unchanged, marked unchecked.
    """
    solver = dict(result.solver)
    if BOTTOM_KEY not in result.convergence:
        solver["equilibrium"] = {"checked": False, "reason": "no bottom reactions in the log"}
        return replace(result, solver=solver, off_equilibrium=None)
    conv = dict(result.convergence)
    indenter_q = np.asarray(conv.get(INDENTER_KEY, result.force_quarter), float)
    bottom_q = np.asarray(conv[BOTTOM_KEY], float)
    flags = off_equilibrium_steps(SYMMETRY_FACTOR * indenter_q, SYMMETRY_FACTOR * bottom_q, tolerance)
    conv[INDENTER_KEY] = indenter_q
    conv[IMBALANCE_KEY] = relative_imbalance(indenter_q, bottom_q, tolerance.absolute_mN / SYMMETRY_FACTOR)
    solver["equilibrium"] = {
        "checked": True,
        "relative_tol": tolerance.relative,
        "absolute_tol_mN": tolerance.absolute_mN,
        "off_equilibrium_depths_mm": [float(d) for d in np.asarray(result.depth)[flags]],
    }
    force = np.where(flags, np.nan, SYMMETRY_FACTOR * indenter_q)
    return replace(result, force=force, convergence=conv, solver=solver, off_equilibrium=flags)


def off_equilibrium_message(result: SimulationResult) -> str | None:
    """One line naming the flagged depths, or None when there are none."""
    depths = result.off_equilibrium_depths
    if not depths:
        return None
    listed = ", ".join(f"{d:g}" for d in depths)
    imbalance = np.abs(np.asarray(result.convergence.get(IMBALANCE_KEY, []), float))
    finite = imbalance[np.isfinite(imbalance)]
    worst = f"; largest imbalance {100 * finite.max():.3g} %" if finite.size else ""
    return (
        f"FEBio accepted {len(depths)} step(s) off equilibrium (indenter reaction != bottom "
        f"reaction) at depth {listed} mm{worst}: their forces are left out (NaN)"
    )


def equilibrium_notes(result: SimulationResult) -> list[str]:
    """Lines for the user about a FEBio result's equilibrium: the flagged depths, the rerun and
    what it kept, or that the check could not be made. Empty for a clean or embedded result."""
    notes = []
    rerun = result.solver.get("rerun")
    if rerun:
        notes.append(
            f"FEBio steps off equilibrium ({rerun['reason']}): reran with tightened settings "
            f"({', '.join(rerun['settings_changed'])}); {rerun['outcome']}; kept the {rerun['kept']} run"
        )
    flagged = off_equilibrium_message(result)
    if flagged:
        notes.append(flagged)
    check = result.solver.get("equilibrium")
    if check is not None and not check.get("checked", False):
        notes.append(f"FEBio equilibrium not checked: {check.get('reason', 'unknown')}")
    return notes
