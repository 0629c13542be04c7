"""What a surrogate is trained on (:class:`TrainingData`): parameter points and their responses,
read from a campaign with the steps a point did not finish filled in and marked; several
campaigns of one test merged into one (:func:`merged_training_data`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..campaign.loader import fill_missing_steps

__all__ = ["TrainingData", "merged_training_data"]

#: The parts of a campaign's model its points set (merged campaigns may differ there only).
_VARIED = {"material": ("c1", "c5"), "contact": ("friction",)}


@dataclass
class TrainingData:
    """Parameter points and their responses: what a surrogate is trained on.

    Usually a campaign (:meth:`from_campaign`, see ``campaign.loader.CampaignData``).

    Attributes
    ----------
    theta : numpy.ndarray
        (n, p) parameters, kPa.
    force : numpy.ndarray
        (n, steps) indentation force, mN (missing steps filled).
    displacement : numpy.ndarray
        (n, steps, nodes, 3) top-surface displacements, mm.
    depth : numpy.ndarray
        (steps,) indentation depth, mm.
    top_xyz : numpy.ndarray
        (nodes, 3) reference coordinates of the top-surface nodes, mm.
    parameters : tuple of str, default ("c1", "c5")
        The parameter of each column of ``theta``.
    source : dict
        Where the data came from (recorded in the surrogate's meta).
    missing : numpy.ndarray or None
        (n, steps) True at forces the campaign does not have (FEBio steps flagged off
        equilibrium), filled in ``force``; validation errors leave them out.
    """

    theta: np.ndarray  # (n, p) kPa
    force: np.ndarray  # (n, steps) mN
    displacement: np.ndarray  # (n, steps, nodes, 3) mm
    depth: np.ndarray  # (steps,) mm
    top_xyz: np.ndarray  # (nodes, 3) mm
    parameters: tuple[str, ...] = ("c1", "c5")
    source: dict[str, Any] = field(default_factory=dict)
    # (n, steps) bool: forces the campaign does not have (FEBio steps flagged off equilibrium),
    # filled in ``force`` by :func:`campaign.loader.fill_missing_steps`; validation errors leave them out
    missing: np.ndarray | None = None

    @classmethod
    def from_campaign(cls, data) -> TrainingData:
        """A campaign's done points as training data, missing forces filled.

        A step without a force (a FEBio step flagged off equilibrium) is filled from the same
        point's finite steps (:func:`campaign.loader.fill_missing_steps`) and marked in
        ``missing``.

        Parameters
        ----------
        data : CampaignData
            The loaded campaign.

        Returns
        -------
        TrainingData
            The points, their responses and the campaign as ``source``.
        """
        force, missing = fill_missing_steps(data.force, data.depth)
        return cls(
            data.theta,
            force,
            displacement=data.displacement,
            depth=data.depth,
            top_xyz=data.top_xyz,
            parameters=data.parameters,
            source=data.spec,
            missing=missing if missing.any() else None,
        )

    def subset(self, rows: np.ndarray) -> TrainingData:
        """The data at some of the points.

        Parameters
        ----------
        rows : numpy.ndarray
            Indices (or a mask) of the points kept.

        Returns
        -------
        TrainingData
            Those points, the same depths and nodes.
        """
        return TrainingData(
            self.theta[rows],
            self.force[rows],
            displacement=self.displacement[rows],
            depth=self.depth,
            top_xyz=self.top_xyz,
            parameters=self.parameters,
            source=self.source,
            missing=None if self.missing is None else self.missing[rows],
        )

    @property
    def n(self) -> int:
        """The number of points."""
        return len(self.theta)


def merged_training_data(datas: Sequence[TrainingData], *, stick_mu: float | None = None) -> TrainingData:
    """Campaigns of one test and mesh merged into one over (c1, c5, mu).

    A campaign with a mu axis keeps its points; a perfect-stick campaign over (c1, c5) gets mu =
    ``stick_mu`` (e.g. the range end of a stick-plus-slip low level's mu, where nothing slips:
    contact-L3 at R = 4.77 mm, {9.81, 218.4} kPa, mu = 3 within 0.005 % in force and 0.018 mm in
    the field of the stick's; docs/validation/model-error.md). So a multi-fidelity discrepancy
    learned at the stick and with friction is one GP over (c1, c5, mu).

    Parameters
    ----------
    datas : sequence of TrainingData
        The campaigns (each over (c1, c5) with the stick, or (c1, c5, mu) with friction an axis).
    stick_mu : float, optional
        The mu a stick campaign's points take; needed when there is one.

    Returns
    -------
    TrainingData
        All points over (c1, c5, mu); its source is the first campaign's with ``name`` joined by
        "+", ``merged`` (each one's source) and ``stick_mu``.

    Raises
    ------
    ValueError
        If the campaigns are not of one test and mesh (depths, top nodes, model apart from
        friction), one holds mu fixed (its model's friction: neither stick nor an axis), one is
        over other parameters, or a stick campaign is given without ``stick_mu``.
    """
    if not datas:
        raise ValueError("no campaign to merge")
    first = datas[0]
    thetas, problems = [], []
    for k, d in enumerate(datas):
        name = (d.source or {}).get("name", f"campaign {k + 1}")
        model = dict((d.source or {}).get("model") or {})
        friction = (model.get("contact") or {}).get("friction")
        if friction is not None:
            problems.append(f"{name}: its mu is held at {friction:g} (neither the stick nor an axis)")
        if tuple(d.parameters) == ("c1", "c5", "mu"):
            thetas.append(np.asarray(d.theta, float))
        elif tuple(d.parameters) == ("c1", "c5"):
            if stick_mu is None:
                problems.append(
                    f"{name}: a stick campaign over (c1, c5) needs stick_mu, the mu it is taken as"
                )
            else:
                thetas.append(np.column_stack([d.theta, np.full(d.n, float(stick_mu))]))
        else:
            problems.append(f"{name}: parameters {tuple(d.parameters)}, not (c1, c5) or (c1, c5, mu)")
        if d.depth.shape != first.depth.shape or not np.allclose(d.depth, first.depth, rtol=0, atol=1e-9):
            problems.append(f"{name}: depths differ from the first campaign's")
        if d.top_xyz.shape != first.top_xyz.shape or not np.allclose(
            d.top_xyz, first.top_xyz, rtol=0, atol=1e-9
        ):
            problems.append(f"{name}: top nodes differ from the first campaign's (another mesh)")
        base = dict((first.source or {}).get("model") or {})
        for key in sorted(set(model) | set(base)):
            here, there = model.get(key), base.get(key)
            if key in _VARIED:  # what a campaign's points set: its parameters, friction
                here = {k: v for k, v in (here or {}).items() if k not in _VARIED[key]}
                there = {k: v for k, v in (there or {}).items() if k not in _VARIED[key]}
            if here != there:
                problems.append(f"{name}: model {key} {here} differs from the first campaign's {there}")
    if problems:
        raise ValueError("the campaigns cannot be merged: " + "; ".join(problems))
    missing = None
    if any(d.missing is not None for d in datas):
        missing = np.vstack(
            [d.missing if d.missing is not None else np.zeros(d.force.shape, bool) for d in datas]
        )
    names = [(d.source or {}).get("name", f"campaign {k + 1}") for k, d in enumerate(datas)]
    source = {**(first.source or {}), "name": "+".join(names), "merged": [d.source for d in datas]}
    if stick_mu is not None:
        source["stick_mu"] = float(stick_mu)
    return TrainingData(
        np.vstack(thetas),
        np.vstack([d.force for d in datas]),
        np.concatenate([d.displacement for d in datas]),
        np.asarray(first.depth, float),
        np.asarray(first.top_xyz, float),
        ("c1", "c5", "mu"),
        source,
        missing,
    )
