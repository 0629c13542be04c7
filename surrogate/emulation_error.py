"""A surrogate's own error, kept with it so that a fit on it can carry it in its bounds (issue 46).

The surrogate is compared with the FE model at points it was not trained on (a test campaign, or
the held-out fold of a k-fold cross-validation): at each such point k the error vector

    e_k = [log F_fe - log F_sur (per step),  u_fe - u_sur (steps x nodes x 3, mm)]

is what the surrogate gets wrong in the two outputs eq. 4a and 4b weigh. The errors of all points
are kept, compressed by a truncated SVD (``E = scores @ directions``, the directions that hold all
but ``1 - energy`` of the sum of squares), in the surrogate's file. A fit reads them at its own
objective and parameters (``inference.budgets.model_error``): each e_k moves the residuals and so the fit,
and the spread of those moves over the held-out points is the surrogate's part of the bounds.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from itertools import pairwise

import numpy as np

from .base import FieldSurrogate, TrainingData

__all__ = ["DISCREPANCY_PREFIX", "EMULATION_ENERGY", "EmulationError", "held_out_errors"]

#: Share of the held-out errors' sum of squares the kept SVD directions hold.
EMULATION_ENERGY = 0.9999

_PREFIX = "emulation_error."
#: The array names' prefix of a multi-fidelity surrogate's discrepancy errors (its k-fold held-out
#: errors at the high-fidelity points), kept beside its low level's own.
DISCREPANCY_PREFIX = "discrepancy_error."


def held_out_errors(surrogate: FieldSurrogate, data: TrainingData) -> np.ndarray:
    """The surrogate's error vectors at ``data``'s points (the FE responses minus the surrogate's).

    Parameters
    ----------
    surrogate : FieldSurrogate
        A trained surrogate (any Predictor over ``data.parameters``).
    data : TrainingData
        Points it was not trained on and their FE responses.

    Returns
    -------
    numpy.ndarray
        (n, steps + steps * nodes * 3): log force per step (0 where the campaign has no force),
        then the displacement field, mm.
    """
    pred = surrogate.predict(data.theta)
    force = np.log(data.force) - np.log(pred.force)
    if data.missing is not None:
        force = np.where(data.missing, 0.0, force)
    field = (data.displacement - pred.displacement).reshape(data.n, -1)
    return np.hstack([force, field])


@dataclass(frozen=True)
class EmulationError:
    """A surrogate's errors at held-out points, compressed: ``errors() = scores @ directions``.

    Attributes
    ----------
    theta : numpy.ndarray
        (n, p) the held-out points, kPa (and mu).
    scores : numpy.ndarray
        (n, r) each point's error in the kept directions.
    directions : numpy.ndarray
        (r, steps + steps * nodes * 3) directions of the output space (orthonormal as the SVD
        makes them; moved linearly to other nodes by :meth:`carried`).
    steps : int
        Steps of the force curve (the first ``steps`` entries of a direction are log force).
    source : str
        Where the points came from, in words (e.g. "5-fold cross-validation of 512 points").
    energy : float
        Share of the errors' sum of squares the directions hold.
    """

    theta: np.ndarray
    scores: np.ndarray
    directions: np.ndarray
    steps: int
    source: str
    energy: float

    @classmethod
    def from_errors(
        cls,
        theta: np.ndarray,
        errors: np.ndarray,
        *,
        steps: int,
        source: str,
        energy: float = EMULATION_ENERGY,
    ) -> EmulationError:
        """Compress held-out error vectors by a truncated SVD.

        Parameters
        ----------
        theta : numpy.ndarray
            (n, p) the held-out points.
        errors : numpy.ndarray
            (n, m) their error vectors (:func:`held_out_errors`).
        steps : int
            Steps of the force curve.
        source : str
            Where the points came from, in words.
        energy : float, default EMULATION_ENERGY
            Share of the sum of squares to keep.

        Returns
        -------
        EmulationError
            The compressed errors.
        """
        errors = np.asarray(errors, float)
        if (
            errors.ndim != 2
            or len(errors) != len(theta)
            or len(errors) == 0
            or not np.all(np.isfinite(errors))
        ):
            raise ValueError(
                f"held-out errors must be a finite (points, outputs) array, got shape {errors.shape}"
            )
        U, s, Vt = np.linalg.svd(errors, full_matrices=False)
        total = float(np.sum(s**2))
        rank = 1 if total == 0 else int(np.searchsorted(np.cumsum(s**2) / total, energy) + 1)
        rank = min(rank, len(s))
        kept = 1.0 if total == 0 else float(np.sum(s[:rank] ** 2) / total)
        return cls(
            theta=np.asarray(theta, float),
            scores=(U[:, :rank] * s[:rank]).astype(np.float32),
            directions=Vt[:rank].astype(np.float32),
            steps=int(steps),
            source=source,
            energy=kept,
        )

    @property
    def points(self) -> int:
        """Number of held-out points."""
        return len(self.theta)

    def errors(self) -> np.ndarray:
        """(n, m) the held-out error vectors, as kept."""
        return self.scores.astype(float) @ self.directions.astype(float)

    def carried(self, field_map) -> EmulationError:
        """The errors with their field moved to other top nodes (a multi-fidelity surrogate's).

        The map is linear (an interpolation between the two levels' top nodes), so the directions
        are moved and the scores kept: no new SVD, and a file can keep the errors at the low level's
        nodes (a few times fewer numbers) and move them when it is read.

        Parameters
        ----------
        field_map : callable
            A linear map (n, steps, nodes, 3) -> (n, steps, nodes', 3).

        Returns
        -------
        EmulationError
            The same errors on the new nodes (their directions no longer orthonormal).
        """
        d = self.directions.astype(float)
        field = d[:, self.steps :].reshape(len(d), self.steps, -1, 3)
        moved = np.asarray(field_map(field)).reshape(len(d), -1)
        return replace(self, directions=np.hstack([d[:, : self.steps], moved]).astype(np.float32))

    def width(self, nodes: int) -> int:
        """The length of an error vector over ``nodes`` top nodes (log force, then the field).

        Parameters
        ----------
        nodes : int
            Top nodes.

        Returns
        -------
        int
            ``steps + steps * nodes * 3``.
        """
        return self.steps + self.steps * nodes * 3

    def describe(self) -> dict:
        """What meta records of it (JSON-ready)."""
        rms = np.sqrt(np.mean(self.errors() ** 2, axis=0))
        return {
            "points": self.points,
            "source": self.source,
            "rank": int(self.directions.shape[0]),
            "energy": self.energy,
            "force_rms_pct": 100.0 * float(np.sqrt(np.mean(rms[: self.steps] ** 2))),
            "field_rms_mm": float(np.sqrt(np.mean(rms[self.steps :] ** 2))),
        }

    def describe_bands(self, column: int, edges) -> list[dict]:
        """:meth:`describe`'s RMS errors within bands of one parameter (e.g. mu's).

        Parameters
        ----------
        column : int
            The parameter (column of :attr:`theta`).
        edges : sequence of float
            The bands' edges, increasing: band k holds ``edges[k] <= theta < edges[k + 1]``.

        Returns
        -------
        list of dict
            Per band: ``low``, ``high``, ``points``, ``force_rms_pct`` and ``field_rms_mm`` (None
            where the band holds no point).
        """
        e, value = self.errors(), self.theta[:, column]
        out = []
        for low, high in pairwise(edges):
            rows = (value >= low) & (value < high)
            band = e[rows]
            out.append(
                {
                    "low": float(low),
                    "high": float(high),
                    "points": int(rows.sum()),
                    "force_rms_pct": 100.0 * float(np.sqrt(np.mean(band[:, : self.steps] ** 2)))
                    if len(band)
                    else None,
                    "field_rms_mm": float(np.sqrt(np.mean(band[:, self.steps :] ** 2)))
                    if len(band)
                    else None,
                }
            )
        return out

    def to_arrays(self, prefix: str = _PREFIX) -> dict[str, np.ndarray]:
        """The named arrays a surrogate file keeps (meta keeps :meth:`describe`).

        Parameters
        ----------
        prefix : str, optional
            The names' prefix (:data:`DISCREPANCY_PREFIX` for a discrepancy's errors).

        Returns
        -------
        dict of str to numpy.ndarray
        """
        return {
            f"{prefix}theta": self.theta,
            f"{prefix}scores": self.scores,
            # half precision: a direction's entries are kept to 1 part in 2,000, far finer than a
            # spread of errors needs, in half the bytes (most of a shipped file)
            f"{prefix}directions": self.directions.astype(np.float16),
            f"{prefix}steps": np.array([self.steps]),
            f"{prefix}energy": np.array([self.energy]),
        }

    @classmethod
    def from_arrays(
        cls, arrays: dict[str, np.ndarray], source: str, *, prefix: str = _PREFIX
    ) -> EmulationError | None:
        """The errors a file kept, or None when it kept none.

        Parameters
        ----------
        arrays : dict of str to numpy.ndarray
            The file's named arrays (:meth:`to_arrays`'s among them).
        source : str
            Where the held-out points came from (the file's ``meta['emulation_error']``).
        prefix : str, optional
            The names' prefix they were kept under.

        Returns
        -------
        EmulationError or None
            The errors, or None.
        """
        if f"{prefix}scores" not in arrays:
            return None
        return cls(
            theta=np.asarray(arrays[f"{prefix}theta"], float),
            scores=np.asarray(arrays[f"{prefix}scores"]),
            directions=np.asarray(arrays[f"{prefix}directions"], np.float32),
            steps=int(arrays[f"{prefix}steps"][0]),
            source=source,
            energy=float(arrays[f"{prefix}energy"][0]),
        )
