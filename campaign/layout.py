"""The layout of a campaign store ``runs/<name>/`` (:class:`StoreLayout`): where each of its
files lives. ``campaign.json`` (the spec and code version) and ``campaign.sha256`` (its sha256),
``index.parquet`` (one row per point), ``points/<n>.npz`` (a point's result, written atomically
by the run's parent process) and ``points/<n>.partial.npz`` (a failed point's finished steps),
``checkpoints/<n>.pkl`` (an embedded point's state after a finished step, written at most every
30 s and kept while it is unfinished, so that a stopped point resumes there), ``leases/<n>.json`` (a run's claim on a point),
``damaged/`` (files that failed their check,
kept to look at) and ``.lock`` (the store's short file lock)."""

from __future__ import annotations

from pathlib import Path

__all__ = ["StoreLayout"]


class StoreLayout:
    """The files of one campaign store, by what they hold.

    Parameters
    ----------
    root : str or pathlib.Path
        The campaign folder (``runs/<name>/``).
    """

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)

    @property
    def spec_path(self) -> Path:
        """The campaign's spec, ``campaign.json``."""
        return self.root / "campaign.json"

    @property
    def spec_sha256_path(self) -> Path:
        """The sha256 of ``campaign.json`` as written, ``campaign.sha256``."""
        return self.root / "campaign.sha256"

    @property
    def index_path(self) -> Path:
        """The index of points, ``index.parquet``."""
        return self.root / "index.parquet"

    @property
    def lock_path(self) -> Path:
        """The store's file lock, ``.lock``."""
        return self.root / ".lock"

    @property
    def damaged_dir(self) -> Path:
        """The folder of files that failed their check, ``damaged/``."""
        return self.root / "damaged"

    @property
    def points_dir(self) -> Path:
        """The folder of the points' result files, ``points/``."""
        return self.root / "points"

    @property
    def leases_dir(self) -> Path:
        """The folder of the claims' lease files, ``leases/``."""
        return self.root / "leases"

    def result_path(self, point: int) -> Path:
        """The result file of ``point``, ``points/<point>.npz``.

        Parameters
        ----------
        point : int
            The point's number in the design.

        Returns
        -------
        pathlib.Path
        """
        return self.points_dir / f"{point:05d}.npz"

    def partial_path(self, point: int) -> Path:
        """The file of failed ``point``'s finished steps, ``points/<point>.partial.npz``.

        Parameters
        ----------
        point : int
            The point's number in the design.

        Returns
        -------
        pathlib.Path
        """
        return self.points_dir / f"{point:05d}.partial.npz"

    @property
    def checkpoints_dir(self) -> Path:
        """The folder of unfinished points' restart files, ``checkpoints/``."""
        return self.root / "checkpoints"

    def checkpoint_path(self, point: int) -> Path:
        """The restart file of ``point`` while it is unfinished, ``checkpoints/<point>.pkl``.

        :meth:`forward.solver.EmbeddedSolver.run`'s ``checkpoint``.

        Parameters
        ----------
        point : int
            The point's number in the design.

        Returns
        -------
        pathlib.Path
        """
        return self.checkpoints_dir / f"{point:05d}.pkl"

    def lease_path(self, point: int) -> Path:
        """The lease file of ``point``, ``leases/<point>.json``.

        Parameters
        ----------
        point : int
            The point's number in the design.

        Returns
        -------
        pathlib.Path
        """
        return self.leases_dir / f"{point:05d}.json"
