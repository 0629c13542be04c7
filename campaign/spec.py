"""What a campaign computes (:class:`CampaignSpec`): a design of parameter points on one model and
solver, as ``campaign.json`` records it (its layout, :data:`SCHEMA`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..forward.spec import ModelSpec
from .designs import Design
from .errors import CampaignError

__all__ = ["CAMPAIGN_EQUILIBRIUM_REL", "SCHEMA", "CampaignSpec"]

SCHEMA = "indentation-studio/campaign/1"
#: Default equilibrium tolerance of FEBio campaign points: 2 % of the step's own force, the
#: force noise a fit assumes at that step (eq. 4a weighs each step relative to its own force).
CAMPAIGN_EQUILIBRIUM_REL = 0.02


@dataclass(frozen=True)
class CampaignSpec:
    """What a campaign computes: a design of parameter points on one model and solver.

    Parameters
    ----------
    name : str
        The campaign's folder name (no path separator, not starting with a dot).
    design : Design
        The parameter points.
    model : ModelSpec
        The forward model every point is solved with.
    solver : {"embedded", "febio"}, default "embedded"
        The forward solver.
    extra : dict, optional
        Further settings, e.g. ``equilibrium_rel`` (FEBio, see :attr:`equilibrium_rel`).

    Raises
    ------
    CampaignError
        If the name is not a plain folder name or the solver is unknown.
    """

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
        """The spec as ``campaign.json`` records it.

        Returns
        -------
        dict
            The schema, name, design (description, parameters, points), model, solver and extra.
        """
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
        """The spec a ``campaign.json`` records (the inverse of :meth:`to_dict`).

        Parameters
        ----------
        d : dict
            The JSON's content.

        Returns
        -------
        CampaignSpec
            The spec.
        """
        des = d["design"]
        return cls(
            name=d["name"],
            design=Design(np.array(des["points"], float), tuple(des["parameters"]), des["description"]),
            model=ModelSpec.from_dict(d["model"]),
            solver=d.get("solver", "embedded"),
            extra=d.get("extra", {}),
        )

    def differences(self, other: CampaignSpec) -> list[str]:
        """What makes ``other`` a different campaign (empty when it is the same).

        Parameters
        ----------
        other : CampaignSpec
            The spec to compare with.

        Returns
        -------
        list of str
            The model fields, solver, design and (FEBio) equilibrium tolerance that differ.
        """
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
        if self.solver == "febio" and self.equilibrium_rel != other.equilibrium_rel:
            out.append(f"equilibrium tolerance ({self.equilibrium_rel:g} vs {other.equilibrium_rel:g})")
        return out

    @property
    def equilibrium_rel(self) -> float:
        """The fraction of a step's own force a FEBio step's imbalance may reach before it is flagged.

        README, "Campaigns"; ``campaign run --equilibrium-tol``.
        """
        return float(self.extra.get("equilibrium_rel", CAMPAIGN_EQUILIBRIUM_REL))


def _changed_fields(a: Any, b: Any, prefix: str = "") -> list[str]:
    """The leaves where two nested dicts differ, as 'path: old -> new'."""
    if isinstance(a, dict) and isinstance(b, dict):
        out: list[str] = []
        for key in sorted(set(a) | set(b)):
            out += _changed_fields(a.get(key), b.get(key), f"{prefix}{key}.")
        return out
    return [] if a == b else [f"{prefix.rstrip('.')}: {a!r} -> {b!r}"]
