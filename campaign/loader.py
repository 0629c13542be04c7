"""A finished campaign as arrays, for the surrogates and the design tools, and as a tidy table."""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ..forward.febio.equilibrium import check_equilibrium
from ..forward.predictor import Prediction
from ..forward.result import SimulationResult
from ..forward.spec import ModelSpec
from .errors import CampaignError
from .store import CampaignStore


@dataclass
class CampaignData:
    """The done points of a campaign, as arrays; steps are 1..N_s (depth 0 left out, as in a Prediction).

    Attributes
    ----------
    theta : numpy.ndarray
        (n, p) parameters of the points, kPa.
    force : numpy.ndarray
        (n, steps) indentation force of the whole specimen, mN; NaN where a step has no force.
    displacement : numpy.ndarray
        (n, steps, nodes, 3) displacements of the top-surface nodes, mm.
    depth : numpy.ndarray
        (steps,) indentation depth, mm.
    top_xyz : numpy.ndarray
        (nodes, 3) reference coordinates of the top-surface nodes, mm.
    top_node_ids : numpy.ndarray
        (nodes,) mesh node numbers of those nodes.
    parameters : tuple of str
        The parameter of each column of ``theta``.
    points : numpy.ndarray
        (n,) the points' numbers in the store.
    spec : dict
        The campaign spec (``campaign.json``).
    left_out : dict of int to str
        Done points left out (fewer than two finite forces) -> why.
    missing : numpy.ndarray or None
        (n, steps) True at steps without a finite force (FEBio steps flagged off equilibrium);
        None when every force is finite.
    """

    theta: np.ndarray  # (n, p) kPa
    force: np.ndarray  # (n, steps) mN, whole specimen
    displacement: np.ndarray  # (n, steps, nodes, 3) mm
    depth: np.ndarray  # (steps,) mm
    top_xyz: np.ndarray  # (nodes, 3) mm
    top_node_ids: np.ndarray  # (nodes,)
    parameters: tuple[str, ...]
    points: np.ndarray  # (n,) point numbers in the store
    spec: dict[str, Any]  # the campaign spec (campaign.json)
    left_out: dict[int, str] = field(default_factory=dict)  # done points with fewer than 2 finite forces
    # (n, steps) bool: steps without a force (FEBio steps flagged off equilibrium: NaN in ``force``);
    # None when every force is finite
    missing: np.ndarray | None = None

    @property
    def n(self) -> int:
        """The number of done points."""
        return len(self.theta)

    def filled_force(self) -> np.ndarray:
        """``force`` with each missing step filled from the same point's finite steps.

        What training and the design tools use (:func:`fill_missing_steps`).

        Returns
        -------
        numpy.ndarray
            (n, steps) forces, mN.
        """
        return fill_missing_steps(self.force, self.depth)[0] if self.missing is not None else self.force

    def prediction(self, filled: bool = False) -> Prediction:
        """The campaign as a Prediction at its points ``theta`` (docs/architecture.md, "The Predictor seam").

        Parameters
        ----------
        filled : bool, default False
            Missing steps filled (:meth:`filled_force`), else NaN.

        Returns
        -------
        Prediction
            Forces, displacements, depths and top nodes (no Jacobians).
        """
        force = self.filled_force() if filled else self.force
        return Prediction(force, self.displacement, self.depth, self.top_xyz, self.parameters)


def fill_missing_steps(force: np.ndarray, depth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``force`` (n, steps) with each non-finite entry filled from the same point's finite steps:
    log force interpolated linearly in log depth (the indentation force is locally a power law
    of depth, so one missing step between two finite ones is filled to a small fraction of a
    percent), extrapolated from the two nearest finite steps at the ends. Returns the filled
    array and the mask of what was filled. A row needs two finite, positive forces."""
    force = np.array(force, float)
    missing = ~np.isfinite(force)
    x = np.log(np.asarray(depth, float))
    for row in np.flatnonzero(missing.any(axis=1)):
        ok = ~missing[row] & (force[row] > 0)
        if ok.sum() < 2:
            raise ValueError(f"training point {row}: fewer than two finite forces to fill its missing steps")
        xs, ys = x[ok], np.log(force[row, ok])
        want = missing[row]
        filled = np.interp(x[want], xs, ys)
        lo, hi = x[want] < xs[0], x[want] > xs[-1]
        filled[lo] = ys[0] + (x[want][lo] - xs[0]) * (ys[1] - ys[0]) / (xs[1] - xs[0])
        filled[hi] = ys[-1] + (x[want][hi] - xs[-1]) * (ys[-1] - ys[-2]) / (xs[-1] - xs[-2])
        force[row, want] = np.exp(filled)
    return force, missing


class StoredResponses:
    """A campaign's responses as a Predictor at its own points (no Jacobians).

    What makes synthetic experiments from a campaign on a fine mesh without solving it again.
    ``predict`` refuses (``ValueError``) a point the campaign does not hold, and a Jacobian.

    Parameters
    ----------
    data : CampaignData
        The campaign (:func:`load_campaign`); its spec's model becomes ``spec``.
    """

    def __init__(self, data: CampaignData) -> None:
        self.data = data
        self.parameters = tuple(data.parameters)
        self.spec = ModelSpec.from_dict(data.spec["model"])  # the model the responses were solved on

    def predict(self, theta: np.ndarray, jacobian: bool = False) -> Prediction:
        """The stored responses at points the campaign holds.

        Parameters
        ----------
        theta : numpy.ndarray
            (n, p) points of the campaign, kPa (matched to a relative 1e-9).
        jacobian : bool, default False
            Must be False: stored responses carry no Jacobians.

        Returns
        -------
        Prediction
            Their forces and fields.

        Raises
        ------
        ValueError
            If a Jacobian is asked for, or the campaign holds no response at a point.
        """
        if jacobian:
            raise ValueError("stored responses carry no Jacobians")
        t = np.atleast_2d(np.asarray(theta, float))
        rows = []
        for point in t:
            close = np.flatnonzero(np.all(np.isclose(self.data.theta, point, rtol=1e-9, atol=0), axis=1))
            if close.size == 0:
                raise ValueError(f"the campaign holds no response at {point.tolist()}")
            rows.append(close[0])
        d = self.data
        return Prediction(d.force[rows], d.displacement[rows], d.depth, d.top_xyz, self.parameters)


def open_campaign(
    name_or_path: str | Path, runs_dir: str | Path = "runs", repair: bool = False
) -> CampaignStore:
    """Open a campaign by folder path or by name under ``runs_dir``, its files checked.

    Parameters
    ----------
    name_or_path : str or pathlib.Path
        A folder holding ``campaign.json``, or a campaign name under ``runs_dir``.
    runs_dir : str or pathlib.Path, default "runs"
        Where named campaigns live.
    repair : bool, default False
        Repair what the check finds; otherwise nothing is written and the failures are in
        ``store.problems``.

    Returns
    -------
    CampaignStore
        The opened store.
    """
    p = Path(name_or_path)
    root = p if (p / "campaign.json").is_file() else Path(runs_dir) / str(name_or_path)
    return CampaignStore.open(root, repair=repair)


def require_sound(store: CampaignStore) -> None:
    """A :class:`CampaignError` naming every file of the store that failed its check (a loader
    reads nothing from a store it cannot trust; ``campaign run`` repairs it)."""
    if store.problems:
        listed = "; ".join(f"{p.file}: {p.reason}" for p in store.problems[:10]) + (
            f"; and {len(store.problems) - 10} more" if len(store.problems) > 10 else ""
        )
        raise CampaignError(
            f"campaign {store.spec.name!r}: {len(store.problems)} file(s) fail their check: {listed}. "
            f"Run `indent-studio campaign run --name {store.spec.name}` (same options) to solve those points "
            f"again, or `campaign status` to see them"
        )


def load_point(store: CampaignStore, point: int) -> SimulationResult:
    """One done point's result; a file that cannot be read is a CampaignError naming it."""
    try:
        return SimulationResult.load(store.result_path(point))
    except (ValueError, OSError) as exc:
        raise CampaignError(
            f"campaign {store.spec.name!r}, point {point}: {exc}; `campaign run` solves it again"
        ) from exc


def load_campaign(name_or_path: str | Path, runs_dir: str | Path = "runs") -> CampaignData:
    """Load the arrays of every done point of a campaign (failed and pending points are left out).

    Steps without a finite force, e.g. FEBio steps flagged off equilibrium, stay NaN in ``force``
    and True in ``missing`` (training fills them from the point's own neighbouring steps, see
    :meth:`surrogate.base.TrainingData.from_campaign`); a done point with fewer than two finite
    forces is left out with a warning naming it.

    Parameters
    ----------
    name_or_path : str or pathlib.Path
        A campaign folder, or a campaign name under ``runs_dir`` (:func:`open_campaign`).
    runs_dir : str or pathlib.Path, default "runs"
        Where named campaigns live.

    Returns
    -------
    CampaignData
        The done points' parameters, forces, displacements, depths and top surface.

    Raises
    ------
    CampaignError
        If the store's files fail their check (naming them), no point is done, no done point has
        a usable force curve, or two points differ in their steps or nodes.

    Examples
    --------
    >>> from indentation_studio.campaign import load_campaign
    >>> data = load_campaign("paper")  # doctest: +SKIP
    >>> data.theta.shape  # doctest: +SKIP
    (775, 2)
    """
    store = open_campaign(name_or_path, runs_dir)
    require_sound(store)
    done = store.points_with("done")
    if len(done) == 0:
        raise CampaignError(f"campaign {store.spec.name!r} has no finished points yet")
    results = [load_point(store, i) for i in done]
    done, results, left_out = _usable_force_curves(done, results)
    if left_out:
        warnings.warn(
            f"campaign {store.spec.name!r}: left out points with fewer than two finite forces: "
            + "; ".join(f"{i}: {why}" for i, why in left_out.items()),
            stacklevel=2,
        )
    if len(done) == 0:
        raise CampaignError(f"campaign {store.spec.name!r} has no point with a usable force curve")
    first = results[0]
    for i, r in zip(done, results, strict=True):
        if r.force.shape != first.force.shape or not np.array_equal(r.top_node_ids, first.top_node_ids):
            raise CampaignError(f"point {i}: its result has other steps or nodes than point {done[0]}")
    force = np.stack([r.force[1:] for r in results])
    missing = ~np.isfinite(force)
    return CampaignData(
        theta=store.spec.design.points[done],
        force=force,
        displacement=np.stack([r.displacement[1:] for r in results]),
        depth=np.asarray(first.depth[1:]),
        top_xyz=np.asarray(first.top_xyz),
        top_node_ids=np.asarray(first.top_node_ids),
        parameters=store.spec.design.parameters,
        points=done,
        spec=store.spec.to_dict(),
        left_out=left_out,
        missing=missing if missing.any() else None,
    )


def _equilibrium_checked(result: SimulationResult) -> SimulationResult:
    """A FEBio result from before the equilibrium check (no flag array) checked now."""
    if result.solver.get("name") == "febio" and result.off_equilibrium is None:
        return check_equilibrium(result)
    return result


def _usable_force_curves(
    points: np.ndarray, results: list[SimulationResult]
) -> tuple[np.ndarray, list[SimulationResult], dict[int, str]]:
    """The points with at least two finite forces past depth 0; the others with the reason.

    A FEBio result from before the equilibrium check (no flag array) is checked now, so that no
    force FEBio accepted off equilibrium reaches a surrogate.
    """
    keep, kept, left_out = [], [], {}
    for i, r in zip(points, results, strict=True):
        r = _equilibrium_checked(r)
        finite = np.isfinite(np.asarray(r.force, float)[1:])
        if finite.sum() < 2:
            bad = ~np.isfinite(np.asarray(r.force, float))
            depths = ", ".join(f"{d:g}" for d in np.asarray(r.depth)[bad])
            flagged = r.off_equilibrium is not None and np.array_equal(bad, np.asarray(r.off_equilibrium))
            left_out[int(i)] = f"{'off equilibrium' if flagged else 'no finite force'} at {depths} mm"
            continue
        keep.append(int(i))
        kept.append(r)
    return np.array(keep, dtype=int), kept, left_out


def force_table(store: CampaignStore) -> pd.DataFrame:
    """Tidy table of the done points' forces: one row per point and step.

    Parameters
    ----------
    store : CampaignStore
        An open campaign; its files must pass their check.

    Returns
    -------
    pandas.DataFrame
        Columns ``point``, one per parameter (kPa), ``step``, ``depth_mm``, ``force_mN`` (NaN where a
        FEBio step was off equilibrium); empty with these columns when no point is done.
    """
    rows = []
    names = store.spec.design.parameters
    require_sound(store)
    for i in store.points_with("done"):
        r = _equilibrium_checked(load_point(store, i))
        k = np.arange(len(r.depth))
        block = pd.DataFrame({"point": i, "step": k, "depth_mm": r.depth, "force_mN": r.force})
        for j, name in enumerate(names):
            block.insert(1 + j, name, store.spec.design.points[i, j])
        rows.append(block)
    if not rows:
        return pd.DataFrame(columns=["point", *names, "step", "depth_mm", "force_mN"])
    return pd.concat(rows, ignore_index=True)


def campaign_record(runs_dir: str | Path, name: str) -> dict[str, Any]:
    """What a manifest says of a campaign: its grid, mesh, contact, points, failures and solver time.

    Parameters
    ----------
    runs_dir : str or pathlib.Path
        Where campaigns live.
    name : str
        The campaign's name.

    Returns
    -------
    dict
        ``name``, ``grid``, ``mesh``, ``contact``, ``points``, ``done``, ``failed``, ``solver_wall_s``.
    """
    root = Path(runs_dir) / name
    spec = json.loads((root / "campaign.json").read_text())
    index = pd.read_parquet(root / "index.parquet")
    return {
        "name": name,
        "grid": spec["design"]["description"],
        "mesh": spec["model"]["mesh"]["preset"],
        "contact": spec["model"].get("contact"),
        "points": len(index),
        "done": int((index["status"] == "done").sum()),
        "failed": int((index["status"] == "failed").sum()),
        "solver_wall_s": round(float(index["wall_s"].fillna(0).sum()), 1),
    }
