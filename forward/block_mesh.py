"""The hex8 quarter-block mesh and its node sets (symmetry planes, bottom, top)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class BlockMesh:
    """A hex8 mesh of the quarter block with the node sets the model needs.

    ``nodes`` (n, 3) reference coordinates, mm; ``elements`` (ne, 8) zero-based node indices in
    FEBio's hex8 order; ``node_ids`` (n,) external ids (FEBio's, 1-based); node sets are
    zero-based index arrays. ``top`` is ordered by node id.
    """

    nodes: np.ndarray
    elements: np.ndarray
    node_ids: np.ndarray
    xsym: np.ndarray
    ysym: np.ndarray
    bottom: np.ndarray
    top: np.ndarray
    source: str

    @property
    def n_nodes(self) -> int:
        return int(self.nodes.shape[0])

    @property
    def n_elements(self) -> int:
        return int(self.elements.shape[0])

    @property
    def top_xyz(self) -> np.ndarray:
        return self.nodes[self.top]

    @classmethod
    def from_arrays(
        cls, nodes: np.ndarray, elements: np.ndarray, node_ids: np.ndarray, source: str
    ) -> BlockMesh:
        """Derive the node sets from the coordinates of a quarter block (x, y >= 0)."""
        nodes = np.asarray(nodes, dtype=float)
        lo, hi = nodes.min(axis=0), nodes.max(axis=0)
        tol = 1e-6 * float(np.max(hi - lo))
        if abs(lo[0]) > tol or abs(lo[1]) > tol:
            raise ValueError(
                f"{source}: the block is not a quarter block with symmetry planes x = 0 and y = 0 "
                f"(min x = {lo[0]:g}, min y = {lo[1]:g})"
            )
        sets = {
            "xsym": np.flatnonzero(np.abs(nodes[:, 0]) <= tol),
            "ysym": np.flatnonzero(np.abs(nodes[:, 1]) <= tol),
            "bottom": np.flatnonzero(np.abs(nodes[:, 2] - lo[2]) <= tol),
            "top": np.flatnonzero(np.abs(nodes[:, 2] - hi[2]) <= tol),
        }
        order = np.argsort(node_ids[sets["top"]], kind="stable")
        sets["top"] = sets["top"][order]
        return cls(
            nodes=nodes,
            elements=np.asarray(elements, dtype=np.int64),
            node_ids=np.asarray(node_ids, dtype=np.int64),
            source=source,
            **sets,
        )
