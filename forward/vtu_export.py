"""A simulation as VTU files for ParaView (meshio): the hex8 block with the displacement of every
node at every step, one ``.vtu`` per step and a ``.pvd`` collection that ParaView opens as a time
series (time = indentation depth, mm). FEBio's hex8 node order is VTK's hexahedron order."""

from __future__ import annotations

from pathlib import Path
from xml.sax.saxutils import quoteattr

import meshio
import numpy as np

from ..atomic_write import atomic_write
from .mesh import BlockMesh
from .result import SimulationResult


def write_vtu_series(
    result: SimulationResult, mesh: BlockMesh, folder: str | Path, stem: str = "step"
) -> Path:
    """Write a result as a VTU series: ``folder/<stem>_NNN.vtu`` per step and ``folder/<stem>.pvd``.

    Parameters
    ----------
    result : SimulationResult
        A result carrying every node's displacement (``EmbeddedSolver.run(full_field=True)``).
    mesh : BlockMesh
        Its mesh.
    folder : str or pathlib.Path
        Where to write (made if missing).
    stem : str, default "step"
        The files' stem.

    Returns
    -------
    pathlib.Path
        The .pvd file.

    Raises
    ------
    ValueError
        If the result holds only the top-surface displacements, or not the mesh's nodes.
    """
    if result.full_displacement is None:
        raise ValueError("this result holds only the top-surface displacements: run with full_field=True")
    u = np.asarray(result.full_displacement)
    if u.shape[1:] != mesh.nodes.shape:
        raise ValueError(f"displacements for {u.shape[1]} nodes, mesh has {mesh.n_nodes}")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    entries = []
    for k, (depth, uk) in enumerate(zip(result.depth, u, strict=True)):
        name = f"{stem}_{k:03d}.vtu"
        atomic_write(
            folder / name,
            lambda tmp, k=k, depth=depth, uk=uk: meshio.write(
                tmp,
                meshio.Mesh(
                    mesh.nodes,
                    [("hexahedron", mesh.elements)],
                    point_data={"displacement": uk, "node_id": mesh.node_ids.astype(np.int64)},
                    field_data={"depth_mm": np.array([depth]), "force_mN": np.array([result.force[k]])},
                ),
                file_format="vtu",
            ),
        )
        entries.append(f'  <DataSet timestep="{depth:.6g}" file={quoteattr(name)}/>')
    pvd = folder / f"{stem}.pvd"
    atomic_write(
        pvd,
        '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n <Collection>\n'
        + "\n".join(entries)
        + "\n </Collection>\n</VTKFile>\n",
    )
    return pvd
