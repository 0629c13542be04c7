"""The campaign store ``runs/<name>/``: ``campaign.json`` (the spec and code version), one result
file per point under ``points/`` (written atomically by the solver's ``save``), and
``index.parquet`` (one row per point: parameters, status, wall time, iterations, error).

The result files are the truth: opening a store reconciles the index with them, so a campaign
killed between writing a result and updating the index loses nothing and repeats nothing.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from .. import __version__
from ..atomic_write import atomic_write
from ..forward.result import SimulationResult
from ..forward.spec import ModelSpec
from .designs import Design

SCHEMA = "indentation-studio/campaign/1"
STATUSES = ("pending", "done", "failed")


class CampaignError(ValueError):
    """A campaign that cannot be created, resumed or read; the message says why."""


@dataclass(frozen=True)
class CampaignSpec:
    """What a campaign computes: a design of parameter points on one model and solver."""

    name: str
    design: Design
    model: ModelSpec
    solver: str = "embedded"
    extra: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.name or any(c in self.name for c in "/\\") or self.name.startswith("."):
            raise CampaignError(f"campaign name {self.name!r}: use a plain folder name")
        if self.solver not in ("embedded", "febio"):
            raise CampaignError(f"solver {self.solver!r}: use 'embedded' or 'febio'")

    def to_dict(self) -> dict[str, Any]:
        return {
            "schema": SCHEMA,
            "name": self.name,
            "design": {
                "description": self.design.description,
                "parameters": list(self.design.parameters),
                "points": self.design.points.tolist(),
            },
            "model": self.model.to_dict(),
            "solver": self.solver,
            "extra": self.extra,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> CampaignSpec:
        des = d["design"]
        return cls(
            name=d["name"],
            design=Design(np.array(des["points"], float), tuple(des["parameters"]), des["description"]),
            model=ModelSpec.from_dict(d["model"]),
            solver=d.get("solver", "embedded"),
            extra=d.get("extra", {}),
        )

    def differences(self, other: CampaignSpec) -> list[str]:
        """What makes ``other`` a different campaign (empty when it is the same)."""
        a, b = self.to_dict(), other.to_dict()
        out = (
            ["model " + ", ".join(_changed_fields(a["model"], b["model"]))]
            if a["model"] != b["model"]
            else []
        )
        if a["solver"] != b["solver"]:
            out.append(f"solver ({a['solver']} vs {b['solver']})")
        if a["design"]["parameters"] != b["design"]["parameters"] or not np.array_equal(
            self.design.points, other.design.points
        ):
            out.append(f"design ({a['design']['description']} vs {b['design']['description']})")
        return out


def _changed_fields(a: Any, b: Any, prefix: str = "") -> list[str]:
    """The leaves where two nested dicts differ, as 'path: old -> new'."""
    if isinstance(a, dict) and isinstance(b, dict):
        out: list[str] = []
        for key in sorted(set(a) | set(b)):
            out += _changed_fields(a.get(key), b.get(key), f"{prefix}{key}.")
        return out
    return [] if a == b else [f"{prefix.rstrip('.')}: {a!r} -> {b!r}"]


class CampaignStore:
    """One campaign folder. ``create_or_open`` refuses a spec that differs from the stored one."""

    def __init__(self, root: Path, spec: CampaignSpec, index: pd.DataFrame) -> None:
        self.root = root
        self.spec = spec
        self.index = index

    # ----------------------------------------------------------------- files
    @property
    def points_dir(self) -> Path:
        return self.root / "points"

    def result_path(self, point: int) -> Path:
        return self.points_dir / f"{point:05d}.npz"

    def partial_path(self, point: int) -> Path:
        return self.points_dir / f"{point:05d}.partial.npz"

    # ------------------------------------------------------------ open/create
    @classmethod
    def create_or_open(cls, runs_dir: str | Path, spec: CampaignSpec) -> CampaignStore:
        root = Path(runs_dir) / spec.name
        meta = root / "campaign.json"
        if meta.is_file():
            store = cls.open(root)
            diff = store.spec.differences(spec)
            if diff:
                raise CampaignError(
                    f"campaign {spec.name!r} in {root} was started with a different "
                    f"{', '.join(diff)}; use another --name, or delete the folder to start over"
                )
            return store
        root.mkdir(parents=True, exist_ok=True)
        (root / "points").mkdir(exist_ok=True)
        record = spec.to_dict() | {"code_version": __version__, "created": time.strftime("%Y-%m-%dT%H:%M:%S")}
        atomic_write(meta, json.dumps(record, indent=1))
        store = cls(root, spec, cls._fresh_index(spec))
        store.write_index()
        return store

    @classmethod
    def open(cls, root: str | Path) -> CampaignStore:
        root = Path(root)
        meta = root / "campaign.json"
        if not meta.is_file():
            raise CampaignError(f"{root}: no campaign here (campaign.json missing)")
        try:
            spec = CampaignSpec.from_dict(json.loads(meta.read_text()))
        except (ValueError, KeyError, TypeError) as exc:
            raise CampaignError(f"{meta}: unreadable campaign spec ({exc})") from exc
        index_path = root / "index.parquet"
        # a deep copy: arrays read from parquet may be read-only views
        index = (
            pd.read_parquet(index_path).copy(deep=True) if index_path.is_file() else cls._fresh_index(spec)
        )
        if len(index) != len(spec.design.points):
            raise CampaignError(f"{index_path}: {len(index)} rows for {len(spec.design.points)} points")
        store = cls(root, spec, index)
        store.reconcile()
        return store

    @staticmethod
    def _fresh_index(spec: CampaignSpec) -> pd.DataFrame:
        n = len(spec.design.points)
        table = pd.DataFrame({"point": np.arange(n)})
        for j, k in enumerate(spec.design.parameters):
            table[k] = spec.design.points[:, j]
        table["status"] = pd.Categorical(["pending"] * n, categories=STATUSES)
        table["wall_s"] = np.nan
        table["newton_iterations"] = pd.array([pd.NA] * n, dtype="Int64")
        table["error"] = pd.array([None] * n, dtype="string")
        table["finished"] = pd.array([None] * n, dtype="string")
        return table

    # ------------------------------------------------------------ index upkeep
    def reconcile(self) -> int:
        """Mark done every point whose result file exists, pending every 'done' point whose file
        is gone. Returns how many rows changed."""
        for stale in self.points_dir.glob("*.tmp"):  # a write cut short by a kill: never renamed
            stale.unlink(missing_ok=True)
        have = {int(p.stem) for p in self.points_dir.glob("*.npz") if p.stem.isdigit()}
        status = self.index["status"].astype(str).to_numpy()
        changed = 0
        for i in range(len(self.index)):
            if i in have and status[i] != "done":
                row: dict[str, Any] = {"status": "done", "error": None}
                try:
                    r = SimulationResult.load(self.result_path(i))
                    row |= {"wall_s": r.wall_s, "newton_iterations": r.newton_iterations}
                except ValueError:  # unreadable: solve the point again
                    self.result_path(i).unlink(missing_ok=True)
                    row = {"status": "pending"}
                self.record(i, row, write=False)
                changed += 1
            elif i not in have and status[i] == "done":
                self.record(i, {"status": "pending"}, write=False)
                changed += 1
        if changed:
            self.write_index()
        return changed

    def record(self, point: int, row: dict[str, Any], write: bool = True) -> None:
        for k, v in row.items():
            self.index.loc[point, k] = v
        if write:
            self.write_index()

    def write_index(self) -> None:
        atomic_write(self.root / "index.parquet", lambda tmp: self.index.to_parquet(tmp, index=False))

    # ---------------------------------------------------------------- queries
    def counts(self) -> dict[str, int]:
        c = self.index["status"].astype(str).value_counts()
        return {s: int(c.get(s, 0)) for s in STATUSES}

    def points_with(self, *statuses: str) -> np.ndarray:
        return self.index.loc[self.index["status"].astype(str).isin(statuses), "point"].to_numpy(int)

    def summary(self) -> dict[str, Any]:
        c = self.counts()
        walls = self.index["wall_s"].dropna()
        failed = self.index[self.index["status"].astype(str) == "failed"]
        slowest = self.index.dropna(subset=["wall_s"]).nlargest(5, "wall_s")
        return {
            "name": self.spec.name,
            "folder": str(self.root),
            "points": len(self.index),
            **c,
            "solver_wall_s": float(walls.sum()),
            "median_point_s": float(walls.median()) if len(walls) else None,
            "failures": [
                {"point": int(r.point), "error": str(r.error)} for r in failed.itertuples(index=False)
            ],
            "slowest": [
                {
                    "point": int(r.point),
                    **{k: float(getattr(r, k)) for k in self.spec.design.parameters},
                    "wall_s": float(r.wall_s),
                }
                for r in slowest.itertuples(index=False)
            ],
            "store_bytes": sum(p.stat().st_size for p in self.root.rglob("*") if p.is_file()),
        }
