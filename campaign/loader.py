"""A finished campaign as arrays, for the surrogates and the design tools, and as a tidy table."""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ..forward.febio_equilibrium import check_equilibrium
from ..forward.predictor import Prediction
from ..forward.result import SimulationResult
from .store import CampaignError, CampaignStore


@dataclass
class CampaignData:
    """The done points of a campaign. Steps are 1..N_s (depth 0 left out, as in a Prediction)."""

    theta: np.ndarray  # (n, p) kPa
    force: np.ndarray  # (n, steps) mN, whole specimen
    displacement: np.ndarray  # (n, steps, nodes, 3) mm
    depth: np.ndarray  # (steps,) mm
    top_xyz: np.ndarray  # (nodes, 3) mm
    top_node_ids: np.ndarray  # (nodes,)
    parameters: tuple[str, ...]
    points: np.ndarray  # (n,) point numbers in the store
    spec: dict[str, Any]  # the campaign spec (campaign.json)
    left_out: dict[int, str] = field(default_factory=dict)  # done points without a complete force curve

    @property
    def n(self) -> int:
        return len(self.theta)

    def prediction(self) -> Prediction:
        """The campaign as a Prediction (docs/architecture.md, "The Predictor seam") at its points ``theta``."""
        return Prediction(self.force, self.displacement, self.depth, self.top_xyz, self.parameters)


class StoredResponses:
    """A campaign's responses as a Predictor at its own points (no Jacobians): what makes synthetic
    experiments from a campaign on a fine mesh without solving it again. A point the campaign does
    not hold is refused."""

    def __init__(self, data: CampaignData) -> None:
        self.data = data
        from ..forward.spec import ModelSpec

        self.parameters = tuple(data.parameters)
        self.spec = ModelSpec.from_dict(data.spec["model"])  # the model the responses were solved on

    def predict(self, theta: np.ndarray, jacobian: bool = False) -> Prediction:
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


def open_campaign(name_or_path: str | Path, runs_dir: str | Path = "runs") -> CampaignStore:
    """A campaign by folder path or by name under ``runs_dir``."""
    p = Path(name_or_path)
    root = p if (p / "campaign.json").is_file() else Path(runs_dir) / str(name_or_path)
    return CampaignStore.open(root)


def load_campaign(name_or_path: str | Path, runs_dir: str | Path = "runs") -> CampaignData:
    """Arrays of every done point with a complete force curve (failed and pending points are left
    out, and so, with a warning naming them, are done points with a NaN force, e.g. a FEBio run
    with steps off equilibrium: surrogates learn log(force) at every step)."""
    store = open_campaign(name_or_path, runs_dir)
    done = store.points_with("done")
    if len(done) == 0:
        raise CampaignError(f"campaign {store.spec.name!r} has no finished points yet")
    results = [SimulationResult.load(store.result_path(i)) for i in done]
    done, results, left_out = _complete_force_curves(done, results)
    if left_out:
        warnings.warn(
            f"campaign {store.spec.name!r}: left out points without a complete force curve: "
            + "; ".join(f"{i}: {why}" for i, why in left_out.items()),
            stacklevel=2,
        )
    if len(done) == 0:
        raise CampaignError(f"campaign {store.spec.name!r} has no point with a complete force curve")
    first = results[0]
    for i, r in zip(done, results, strict=True):
        if r.force.shape != first.force.shape or not np.array_equal(r.top_node_ids, first.top_node_ids):
            raise CampaignError(f"point {i}: its result has other steps or nodes than point {done[0]}")
    return CampaignData(
        theta=store.spec.design.points[done],
        force=np.stack([r.force[1:] for r in results]),
        displacement=np.stack([r.displacement[1:] for r in results]),
        depth=np.asarray(first.depth[1:]),
        top_xyz=np.asarray(first.top_xyz),
        top_node_ids=np.asarray(first.top_node_ids),
        parameters=store.spec.design.parameters,
        points=done,
        spec=store.spec.to_dict(),
        left_out=left_out,
    )


def _equilibrium_checked(result: SimulationResult) -> SimulationResult:
    """A FEBio result from before the equilibrium check (no flag array) checked now."""
    if result.solver.get("name") == "febio" and result.off_equilibrium is None:
        return check_equilibrium(result)
    return result


def _complete_force_curves(
    points: np.ndarray, results: list[SimulationResult]
) -> tuple[np.ndarray, list[SimulationResult], dict[int, str]]:
    """The points whose every force is finite; the others with the reason.

    A FEBio result from before the equilibrium check (no flag array) is checked now, so that no
    force FEBio accepted off equilibrium reaches a surrogate.
    """
    keep, kept, left_out = [], [], {}
    for i, r in zip(points, results, strict=True):
        r = _equilibrium_checked(r)
        bad = ~np.isfinite(np.asarray(r.force, float))
        if bad.any():
            depths = ", ".join(f"{d:g}" for d in np.asarray(r.depth)[bad])
            flagged = r.off_equilibrium is not None and np.array_equal(bad, np.asarray(r.off_equilibrium))
            left_out[int(i)] = f"{'off equilibrium' if flagged else 'no finite force'} at {depths} mm"
            continue
        keep.append(int(i))
        kept.append(r)
    return np.array(keep, dtype=int), kept, left_out


def force_table(store: CampaignStore) -> pd.DataFrame:
    """Tidy table of the done points: one row per point and step (point, parameters, step,
    depth_mm, force_mN; NaN where a FEBio step was off equilibrium)."""
    rows = []
    names = store.spec.design.parameters
    for i in store.points_with("done"):
        r = _equilibrium_checked(SimulationResult.load(store.result_path(i)))
        k = np.arange(len(r.depth))
        block = pd.DataFrame({"point": i, "step": k, "depth_mm": r.depth, "force_mN": r.force})
        for j, name in enumerate(names):
            block.insert(1 + j, name, store.spec.design.points[i, j])
        rows.append(block)
    if not rows:
        return pd.DataFrame(columns=["point", *names, "step", "depth_mm", "force_mN"])
    return pd.concat(rows, ignore_index=True)
