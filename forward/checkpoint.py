"""A run's restart file (FEBio's restart dump): its whole state written atomically after each
step, and inside a step cut back after a converged increment (``mid_step``), with the identity of
the run that wrote it, so that a file of another run is refused by name
(docs/explanation/solver.md, "Restart")."""

from __future__ import annotations

import os
import pickle
from pathlib import Path

from .. import __version__

__all__ = [
    "CHECKPOINT_FORMAT",
    "MID_STEP_CHECKPOINT_S",
    "READABLE_CHECKPOINT_FORMATS",
    "CheckpointMismatch",
    "checkpoint_progress",
    "read_checkpoint",
    "run_identity",
    "write_checkpoint",
]

#: the layout of a run's checkpoint; a file of another is refused. 2: it may hold a step's
#: converged increments (``mid_step``); a file of format 1 (whole steps only) is read as one of
#: format 2 without them.
CHECKPOINT_FORMAT = 2
READABLE_CHECKPOINT_FORMATS = (1, 2)
#: Within a step cut into increments, a run with a checkpoint writes one after a converged
#: increment at most this often (seconds): a fine level's hard step can take hours of cut-back
#: increments (contact-L4, R = 4.77 mm, {2.5, 460} kPa: step 28 over an hour in sixteenths), and a
#: stop then loses only the increment under way, not the step.
MID_STEP_CHECKPOINT_S = 120.0


class CheckpointMismatch(ValueError):
    """A checkpoint file that is not this run's.

    Another spec, mesh, sensitivity setting, version or layout, or a file cut short (the message
    names which). Delete it to start the run from the beginning.
    """


def run_identity(spec: dict, mesh: dict, *, sensitivities: bool, full_field: bool) -> dict:
    """What a checkpoint must match to be resumed: the layout, the package's version, the spec,
    the mesh and what the run records.

    Parameters
    ----------
    spec : dict
        The run's spec (:meth:`forward.spec.ModelSpec.to_dict`).
    mesh : dict
        Its mesh's source and sizes.
    sensitivities, full_field : bool
        Whether the run carries sensitivities and every node's displacements.

    Returns
    -------
    dict
    """
    return {
        "format": CHECKPOINT_FORMAT,
        "version": __version__,
        "spec": spec,
        "mesh": mesh,
        "sensitivities": bool(sensitivities),
        "full_field": bool(full_field),
    }


def write_checkpoint(path: Path, identity: dict, state: dict) -> None:
    """Write a run's state with its identity, atomically (a stop while writing leaves the last
    whole file).

    Parameters
    ----------
    path : Path
        The checkpoint file.
    identity : dict
        :func:`run_identity` of the run.
    state : dict
        What the run resumes from.
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as fh:
        pickle.dump({"identity": identity, "state": state}, fh, protocol=pickle.HIGHEST_PROTOCOL)
    os.replace(tmp, path)


def read_checkpoint(path: Path, identity: dict) -> dict:
    """The state in a checkpoint written by the run of ``identity`` (format 1 or 2).

    Parameters
    ----------
    path : Path
        The checkpoint file.
    identity : dict
        :func:`run_identity` of the run that wants to resume.

    Returns
    -------
    dict

    Raises
    ------
    CheckpointMismatch
        The file is cut short or foreign, or another run's (naming what differs).
    """
    try:
        with open(path, "rb") as fh:
            saved = pickle.load(fh)
        written, state = saved["identity"], saved["state"]
    except Exception as exc:  # a truncated or foreign file: say which, never resume from it
        raise CheckpointMismatch(f"{path} is not a readable checkpoint ({exc!r}); delete it") from exc
    differ = [key for key in identity if key != "format" and written.get(key) != identity[key]]
    if written.get("format") not in READABLE_CHECKPOINT_FORMATS:
        differ.insert(0, "format")
    if differ:
        raise CheckpointMismatch(
            f"{path} holds another run's state (its {', '.join(differ)} differ); delete it "
            "to start this run from the beginning"
        )
    return state


def checkpoint_progress(path: Path) -> dict | None:
    """Where the run that wrote a checkpoint stood: its depth (inside a step cut back, the last
    converged increment's), the protocol's final depth, the steps finished and of how many, and
    its solver time. What ``campaign status`` prints for a point that will resume there.

    Parameters
    ----------
    path : Path
        The checkpoint file (a pickle: only checkpoints your own runs wrote).

    Returns
    -------
    dict or None
        ``depth_mm``, ``of_mm``, ``steps_done``, ``steps``, ``elapsed_s``; None where the file is
        not a readable checkpoint.
    """
    try:
        with open(path, "rb") as fh:
            saved = pickle.load(fh)
        state, protocol = saved["state"], saved["identity"]["spec"]["protocol"]
        depths = list(state["depths"])
        mid = state.get("mid_step")
        return {
            "depth_mm": float(mid["depth"] if mid else depths[-1]),
            "of_mm": float(protocol["steps"] * protocol["step_size"]),
            "steps_done": len(depths) - 1,
            "steps": int(protocol["steps"]),
            "elapsed_s": float(state["elapsed_s"]),
        }
    except Exception:  # a file cut short, foreign or of another layout: nothing to say of it
        return None
