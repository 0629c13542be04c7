"""A DIC export read into one shape, whatever program wrote it, and the choice of the frame that
belongs to each indentation step.

Every importer (MatchID, DuoDIC, mapped CSV) returns a :class:`DICSeries`: the reference position
of every point that was correlated in some frame, and each frame's displacement from the
reference state (NaN where the point was not correlated in that frame). The reference state is
the export's own (its zero-displacement frame, before the first step); the experiment format has
no step 0, so that frame is never a step.

Frames are matched to steps either by an explicit list of frame numbers (one per step) or by time:
the last frame taken during each step's hold (from the load-frame record), on the load frame's
clock after ``time_offset_s`` is added to the DIC frame times.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..experiment.data import ExperimentDataError


@dataclass
class DICSeries:
    """A DIC export: ``xyz`` (points, 3) reference positions in mm, ``u`` (frames, points, 3)
    displacements from the reference in mm (NaN: not correlated), ``frame_ids`` the export's frame
    (image) numbers, ``frame_names`` the file or cell each frame came from, ``times_s`` the frame
    times when the export has them."""

    source: str
    xyz: np.ndarray
    u: np.ndarray
    frame_ids: np.ndarray
    frame_names: list[str]
    times_s: np.ndarray | None = None
    notes: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.xyz = np.asarray(self.xyz, float)
        self.u = np.asarray(self.u, float)
        self.frame_ids = np.asarray(self.frame_ids, int)
        if self.u.shape != (len(self.frame_ids), len(self.xyz), 3):
            raise ExperimentDataError(
                f"{self.source}: displacements {self.u.shape} do not match {len(self.frame_ids)} frames "
                f"of {len(self.xyz)} points"
            )
        if len(set(self.frame_ids.tolist())) != len(self.frame_ids):
            raise ExperimentDataError(f"{self.source}: frame numbers repeat: {self.frame_ids.tolist()}")

    @property
    def points_per_frame(self) -> np.ndarray:
        """How many points were correlated in each frame."""
        return np.isfinite(self.u).all(axis=2).sum(axis=1)

    def frame_index(self, frame_id: int, step: int | None = None) -> int:
        """The position of frame ``frame_id`` in this series; an error naming the missing frame."""
        hits = np.flatnonzero(self.frame_ids == int(frame_id))
        if not hits.size:
            for_step = f" (step {step})" if step is not None else ""
            raise ExperimentDataError(
                f"{self.source}: no frame {frame_id}{for_step}; the export has frames "
                f"{_ranges(self.frame_ids)}"
            )
        return int(hits[0])


def _ranges(ids: np.ndarray) -> str:
    """1, 2, 3, 5, 6 -> '1..3, 5..6'."""
    ids = np.sort(np.asarray(ids, int))
    if not ids.size:
        return "none"
    breaks = np.flatnonzero(np.diff(ids) != 1)
    starts = np.concatenate([[ids[0]], ids[breaks + 1]])
    ends = np.concatenate([ids[breaks], [ids[-1]]])
    return ", ".join(f"{a}" if a == b else f"{a}..{b}" for a, b in zip(starts, ends, strict=True))


def require_consecutive_frames(source: str, frame_ids: np.ndarray, names: Sequence[str]) -> None:
    """An error naming the first missing frame when the frame numbers have a gap (a file lost
    from an export folder); the stride of the first two frames is the export's."""
    ids = np.asarray(frame_ids, int)
    if len(ids) < 3:
        return
    stride = ids[1] - ids[0]
    gaps = np.flatnonzero(np.diff(ids) != stride)
    if gaps.size:
        i = int(gaps[0])
        raise ExperimentDataError(
            f"{source}: frame {ids[i] + stride} is missing (between {names[i]} and {names[i + 1]}); "
            f"frames found: {_ranges(ids)}. Restore the file, or name the frame of every step (--frames, e.g. 1:28)"
        )


def frames_by_list(dic: DICSeries, frames: Sequence[int], steps: int) -> np.ndarray:
    """Indices into ``dic`` of the frames named for steps 1..``steps``."""
    if len(frames) != steps:
        raise ExperimentDataError(
            f"{len(frames)} frames were named for the steps, but the protocol has {steps} steps"
        )
    return np.array([dic.frame_index(f, step=k + 1) for k, f in enumerate(frames)])


def frames_by_time(
    dic: DICSeries, hold_windows: np.ndarray, time_offset_s: float = 0.0, times_s: np.ndarray | None = None
) -> np.ndarray:
    """Indices into ``dic`` of the last frame taken during each step's hold (``hold_windows``
    (steps, 2): start and end on the load frame's clock, s; NaN for a step without a hold, which
    gets index -1); ``times_s`` overrides the export's frame times; ``time_offset_s`` is added to
    the frame times."""
    t = dic.times_s if times_s is None else np.asarray(times_s, float)
    if t is None:
        raise ExperimentDataError(
            f"{dic.source}: the export has no frame times; give them, or name the frame of every step"
        )
    if len(t) != len(dic.frame_ids):
        raise ExperimentDataError(f"{len(t)} frame times were given for {len(dic.frame_ids)} frames")
    t = np.asarray(t, float) + time_offset_s
    chosen = []
    for k, (t0, t1) in enumerate(np.asarray(hold_windows, float)):
        if not np.isfinite(t0):
            chosen.append(-1)
            continue
        inside = np.flatnonzero((t >= t0) & (t <= t1))
        if not inside.size:
            near = int(np.argmin(np.minimum(np.abs(t - t0), np.abs(t - t1))))
            raise ExperimentDataError(
                f"{dic.source}: no DIC frame during step {k + 1}'s hold (t = {t0:g} .. {t1:g} s on the load "
                f"frame's clock); the nearest is frame {dic.frame_ids[near]} at {t[near]:g} s "
                "(a frame missing, or the clocks' offset wrong?)"
            )
        chosen.append(int(inside[np.argmax(t[inside])]))
    taken = [c for c in chosen if c >= 0]
    if len(set(taken)) != len(taken):
        raise ExperimentDataError(f"{dic.source}: two steps' holds share a DIC frame")
    return np.array(chosen)
