"""What a surrogate is trained on (:class:`TrainingData`): parameter points and their responses,
read from a campaign with the steps a point did not finish filled in and marked."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..campaign.loader import fill_missing_steps

__all__ = ["TrainingData"]


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
