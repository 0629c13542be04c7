"""The high fidelity's own field error, as a variance the adequacy test allows at each node.

A fit on a surrogate corrected toward ``contact-L3`` carries level 3's discretisation error in its
field: measured against level 4 at the study's points it is 0.01 to 0.03 mm root mean square in
plane near the contact's edge at the last steps, up to 0.12 mm out of plane, beside DIC noise of
0.02 mm (docs/validation/model-error.md, "The candidate, settled"), and the chi-square test of an
experiment made by level 4 flags it (1.06 to 1.07 per degree at R = 4.77 mm). The test's
covariance then gets, at each node and step, the square of level 4 less level 3 as the root mean
square over a band of distance from the axis (``BAND_R`` of the indenter's radius wide), the
largest over the measured pairs: what the study measured, carried to any fit by its node's band
and the step's depth (:func:`field_variance`). The reference is level 4, as the error budgets'
(issue 57's decision 1).

A table is measured from pairs of runs of one test (:func:`field_error_table`), written with its
sources by ``tools/make_field_error_table.py`` and shipped beside the error budgets
(``indentation_studio/error_budgets/field-error-*.json``); :func:`shipped_field_error` finds the
one for a fit's high fidelity.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ...forward.convergence.mesh_study import top_field_interpolator
from ...forward.result import SimulationResult
from ...surrogate.error_budgets import indentation_test_of, shipped_budgets_folder

__all__ = ["BAND_R", "field_error_table", "field_variance", "shipped_field_error"]

#: The width of a band of distance from the axis, in indenter radii.
BAND_R = 0.25
#: Bands beyond this many are one (the far field).
_LAST_BAND = 40


def _bands(xy: np.ndarray, radius: float) -> np.ndarray:
    return np.minimum((np.hypot(xy[:, 0], xy[:, 1]) / (BAND_R * radius)).astype(int), _LAST_BAND)


def field_error_table(pairs: list[tuple[SimulationResult, SimulationResult]], radius: float) -> dict:
    """The root mean square of the fine run's top field less the coarse one's, by band and step.

    Each pair is (coarse, fine) of one point of one test (the same protocol); the fine run's top
    nodes are the sample, the coarse field interpolated there as its own shape functions do. The
    table holds, per step, band and component, the largest over the pairs.

    Parameters
    ----------
    pairs : list of (SimulationResult, SimulationResult)
        (coarse, fine) runs, e.g. contact-L3 and contact-L4 at the study's points.
    radius : float
        The indenter's radius, mm (the bands are ``BAND_R`` of it wide).

    Returns
    -------
    dict
        ``radius``, ``band_r``, ``depths`` (mm, steps 1 to N), ``rms_mm`` (steps, bands, 3).

    Raises
    ------
    ValueError
        If there is no pair, or the pairs' depths differ.
    """
    if not pairs:
        raise ValueError("a field-error table needs at least one (coarse, fine) pair")
    depths = np.asarray(pairs[0][1].depth, float)[1:]
    rms = np.zeros((depths.size, _LAST_BAND + 1, 3))
    for coarse, fine in pairs:
        for run in (coarse, fine):
            if not np.allclose(np.asarray(run.depth, float)[1:], depths):
                raise ValueError("the pairs' runs do not share their depths: one test's runs are needed")
        band = _bands(fine.top_xyz[:, :2], radius)
        counts = np.bincount(band, minlength=_LAST_BAND + 1)
        for k in range(depths.size):
            at = top_field_interpolator(coarse.top_xyz, coarse.displacement[k + 1])(fine.top_xyz[:, :2])
            d2 = (fine.displacement[k + 1] - at) ** 2
            sums = np.stack([np.bincount(band, d2[:, c], minlength=_LAST_BAND + 1) for c in range(3)], axis=1)
            with np.errstate(invalid="ignore", divide="ignore"):
                here = np.sqrt(np.where(counts[:, None] > 0, sums / counts[:, None], 0.0))
            rms[k] = np.maximum(rms[k], here)
    return {"radius": float(radius), "band_r": BAND_R, "depths": depths.tolist(), "rms_mm": rms.tolist()}


def field_variance(table: dict, nodes_xy: np.ndarray, depths: np.ndarray) -> np.ndarray:
    """The table's variance at nodes and depths (the adequacy test's ``field_variance``).

    Parameters
    ----------
    table : dict
        As :func:`field_error_table` makes it.
    nodes_xy : ndarray, shape (m, 2)
        The nodes' reference positions in the block's frame, mm.
    depths : ndarray, shape (s,)
        The steps' depths, mm; each must be one of the table's.

    Returns
    -------
    ndarray, shape (s, m, 3)
        mm^2.

    Raises
    ------
    ValueError
        If a depth is not one of the table's.
    """
    known = np.asarray(table["depths"], float)
    rms = np.asarray(table["rms_mm"], float)
    at = np.abs(known[None, :] - np.asarray(depths, float)[:, None]).argmin(axis=1)
    if np.any(np.abs(known[at] - depths) > 1e-9 * max(1.0, known.max())):
        raise ValueError(
            f"depths {np.asarray(depths).tolist()} are not all among the table's {known.tolist()}"
        )
    band = _bands(np.asarray(nodes_xy, float), float(table["radius"]))
    return rms[at][:, band, :] ** 2


def shipped_field_error(spec, coarse_mesh: str, folder: str | Path | None = None) -> dict | None:
    """The shipped field-error table of ``spec``'s test with ``coarse_mesh`` as its coarse level.

    Parameters
    ----------
    spec : ModelSpec or dict
        The fit's high-fidelity model (its test: geometry, indenter, protocol, contact, material
        but c1 and c5).
    coarse_mesh : str
        The mesh preset whose error the table must hold (the fit's high fidelity, e.g. contact-L3).
    folder : str or pathlib.Path, optional
        Where to look; default the shipped budgets' folder.

    Returns
    -------
    dict or None
        The table with its ``source`` (file, meshes, pairs), or None where none was measured.
    """
    model = spec.to_dict() if hasattr(spec, "to_dict") else dict(spec)
    test = json.loads(json.dumps(indentation_test_of(model)))
    for path in sorted(Path(folder or shipped_budgets_folder()).glob("field-error-*.json")):
        try:
            payload = json.loads(path.read_text())
            same = json.loads(json.dumps(payload["test"])) == test and payload["coarse_mesh"] == coarse_mesh
        except (OSError, ValueError, KeyError, TypeError):
            continue
        if same:
            payload["file"] = f"indentation_studio/error_budgets/{path.name}" if folder is None else str(path)
            return payload
    return None
