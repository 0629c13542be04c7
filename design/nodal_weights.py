"""Nodal weights of the displacement objectives (paper Appendix B, eq. B.1 to B.3) and the mask of
nodes with measured data.

Three readings (the paper as printed, the studio's fits, and the authors' public code):

* ``paper`` (default): B.1 to B.3 as printed, normalised to sum to one over the nodes with data;
  nodes obscured by the indenter (within the sphere's radius of the axis) get weight 0. What
  reproduces the paper (Table 1, Fig. 8) uses it.
* ``fit``: the paper's, with the rings from R to :data:`FIT_INNER_RADII` R left out too: the
  objective of the studio's fits, error budgets and design advice. Near the indenter the field
  converges slowly with the mesh (the fitted c5 moves by up to 24 % between the finest meshes at
  R = 8 mm with the paper's rings; without them 0.5 %), it costs nothing in the noise-only
  half-width, and in a lab those points are the least trustworthy (the surface there is steep to
  the cameras and next to the indenter's shadow): docs/validation/verification.md.
* ``authors``: the authors' code: only nodes in the ring 1.2 R to 5.5 R from the indentation
  point enter; inverse distances with an offset of a tenth of the mean nearest-node spacing;
  not normalised.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

#: Anisotropy factors of B.1 to B.3: weight_j ~ (a_x x^2 + a_y y^2)^(-1/2) for direction j.
DIRECTION_FACTORS = {"ux": (0.1, 1.0), "uy": (1.0, 0.1), "uz": (1.0, 1.0)}


#: The objectives' readings (module docstring).
READINGS = ("paper", "fit", "authors")

#: Where the ``fit`` reading's data begin, in indenter radii from the axis.
FIT_INNER_RADII = 1.5


def check_reading(reading: str) -> str:
    """``reading`` if it is one of :data:`READINGS`.

    Parameters
    ----------
    reading : str
        A reading's name.

    Returns
    -------
    str
        The same name.

    Raises
    ------
    ValueError
        If it is not a known reading.
    """
    if reading not in READINGS:
        raise ValueError(f"unknown reading {reading!r}; use one of {', '.join(READINGS)}")
    return reading


@dataclass(frozen=True)
class NodeSelection:
    """Which top-surface nodes carry data: an annulus ``inner`` <= r <= ``outer`` (mm) around the
    indentation axis, and optionally a user mask (True = measured)."""

    inner: float
    outer: float = np.inf
    mask: np.ndarray | None = None

    def measured(self, xy: np.ndarray) -> np.ndarray:
        r = np.hypot(xy[:, 0], xy[:, 1])
        keep = (r > self.inner) & (r <= self.outer)
        if self.mask is not None:
            m = np.asarray(self.mask, bool)
            if m.shape != keep.shape:
                raise ValueError(f"node mask has {m.size} entries for {keep.size} top nodes")
            keep &= m
        return keep


def default_selection(radius: float, reading: str = "paper", mask: np.ndarray | None = None) -> NodeSelection:
    """The nodes with data by default, as the objective's reading selects them.

    Outside the sphere's radius (paper), outside :data:`FIT_INNER_RADII` radii (fit), or the
    1.2 R to 5.5 R ring (authors' code).

    Parameters
    ----------
    radius : float
        The indenter's radius, mm.
    reading : {"paper", "fit", "authors"}, default "paper"
        The objective's reading (module docstring).
    mask : numpy.ndarray, optional
        (nodes,) True at nodes with data (a DIC field of view, points correlated).

    Returns
    -------
    NodeSelection
        The annulus and the mask.

    Raises
    ------
    ValueError
        An unknown reading.

    Examples
    --------
    >>> import numpy as np
    >>> from indentation_studio.design.nodal_weights import default_selection
    >>> xy = np.array([[4.0, 0.0], [6.0, 0.0], [8.0, 0.0]])  # 0.84, 1.26 and 1.68 R at R = 4.77 mm
    >>> default_selection(4.77).measured(xy).tolist(), default_selection(4.77, "fit").measured(xy).tolist()
    ([False, True, True], [False, False, True])
    """
    check_reading(reading)
    if reading == "paper":
        return NodeSelection(inner=radius, mask=mask)
    if reading == "fit":
        return NodeSelection(inner=FIT_INNER_RADII * radius, mask=mask)
    return NodeSelection(inner=1.2 * radius, outer=5.5 * radius, mask=mask)


def nodal_weights(xy: np.ndarray, measured: np.ndarray, reading: str = "paper") -> dict[str, np.ndarray]:
    """Weights w_j of B.1 (ux), B.2 (uy), B.3 (uz) at nodes ``xy`` (n, 2), zero where not measured.

    ``paper`` and ``fit``: normalised to sum to one over the measured nodes (as B.1 to B.3 print
    them). ``authors``: unnormalised, with an offset of 0.1 x the mean nearest-node spacing under the root.
    """
    xy = np.asarray(xy, float)
    measured = np.asarray(measured, bool)
    if not measured.any():
        raise ValueError("no top-surface node has measured data: every nodal weight would be 0")
    offset = 0.0
    if check_reading(reading) == "authors":
        d, _ = cKDTree(xy).query(xy, k=2)
        offset = 0.1 * float(np.mean(d[:, 1]))
    out = {}
    for name, (ax, ay) in DIRECTION_FACTORS.items():
        dist = np.sqrt(ax * xy[:, 0] ** 2 + ay * xy[:, 1] ** 2) + offset
        w = np.zeros(len(xy))
        with np.errstate(divide="ignore"):
            w[measured] = 1.0 / dist[measured]
        if not np.all(np.isfinite(w)):
            raise ValueError("a measured node sits on the indentation axis: B.1 to B.3 are infinite there")
        out[name] = w if reading == "authors" else w / w.sum()
    return out
