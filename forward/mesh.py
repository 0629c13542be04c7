"""Structured hex8 quarter-block meshes graded toward the indentation point (paper 2.4.1).

The block spans x in [0, half_x], y in [0, half_y], z in [0, height]; the indenter touches
(0, 0, height). Cells are uniform (size ``h0``) in a core around the indentation point and
then grow geometrically to the far faces. Node numbering follows the FEBio files of
FEBio's baseline input (id = 1 + k + nz * (j + ny * i) for grid x[i], y[j], z[k]), so that node ids
of our meshes and of FEBio's coincide when the grids do.
"""

from __future__ import annotations

import lazy_loader as lazy
import numpy as np

from .block_mesh import BlockMesh, grid_block
from .composite_mesh import composite_mesh
from .convergence.mesh_family import contact_mesh
from .feb_mesh import read_feb_block_mesh
from .mesh_presets import CONTACT_MESH_LEVELS, MESH_PRESETS, GradedAxis, MeshPreset
from .spec import Geometry, ModelSpec

#: scipy's root finder, imported on first use: scipy.optimize takes 0.1 to 0.2 s to import and only
#: the graded presets need it (a run on a FEBio file's mesh never does)
optimize = lazy.load("scipy.optimize", suppress_warning=True)

__all__ = [
    "MESH_PRESETS",
    "BlockMesh",
    "GradedAxis",
    "MeshPreset",
    "axis_coordinates",
    "build_mesh",
    "grid_block",
    "preset_mesh",
    "structured_block",
]


def axis_coordinates(axis: GradedAxis, length: float) -> np.ndarray:
    """Node coordinates of ``axis`` from 0 (the fine end) to ``length``: ``n_core`` cells of ``h0``,
    then ``n_graded`` cells growing geometrically (first one ``h0``) to fill the rest."""
    core = axis.h0 * axis.n_core
    rest = length - core
    if rest <= 0:
        raise ValueError(f"core {core:g} mm does not fit in {length:g} mm")
    sizes = [axis.h0] * axis.n_core
    if axis.n_graded > 0:
        n = axis.n_graded
        if rest <= axis.h0 * n:  # would need shrinking cells: fall back to uniform
            sizes += [rest / n] * n
        else:
            r = optimize.brentq(lambda r: axis.h0 * (r**n - 1.0) / (r - 1.0) - rest, 1.0 + 1e-12, 10.0)
            sizes += list(axis.h0 * r ** np.arange(n))
    coords = np.concatenate([[0.0], np.cumsum(sizes)])
    coords[-1] = length
    return coords


def structured_block(geometry: Geometry, preset: MeshPreset, name: str = "custom") -> BlockMesh:
    """The graded structured hex8 mesh of the quarter block for ``preset``.

    Parameters
    ----------
    geometry : Geometry
        The block's half widths and height, mm.
    preset : MeshPreset
        The grading of the x/y and z axes.
    name : str, default "custom"
        The mesh's name (its source is ``preset:<name>``).

    Returns
    -------
    BlockMesh
        The mesh (:func:`grid_block`).
    """
    x = axis_coordinates(preset.xy, geometry.half_x)
    y = axis_coordinates(preset.xy, geometry.half_y)
    z = geometry.height - axis_coordinates(preset.z, geometry.height)[::-1]
    return grid_block(x, y, z, f"preset:{name}")


def preset_mesh(name: str, geometry: Geometry | None = None) -> BlockMesh:
    """The named preset mesh of ``MESH_PRESETS``.

    Parameters
    ----------
    name : str
        A key of ``MESH_PRESETS`` (e.g. ``"default"``).
    geometry : Geometry, optional
        The block; default ``Geometry()``.

    Returns
    -------
    BlockMesh
        The graded structured mesh (:func:`structured_block`).

    Raises
    ------
    ValueError
        If the preset is unknown.
    """
    if name not in MESH_PRESETS:
        raise ValueError(f"unknown mesh preset {name!r}; use one of {sorted(MESH_PRESETS)}")
    return structured_block(geometry or Geometry(), MESH_PRESETS[name], name)


def build_mesh(spec: ModelSpec) -> BlockMesh:
    """The block mesh a spec asks for: a preset, or a FEBio file's.

    A preset of the composite phantom, or one that follows the spec's indenter
    (``contact-L0`` to ``contact-L4``), is built for that spec.

    Parameters
    ----------
    spec : ModelSpec
        The model; its ``mesh`` names a preset or a ``.feb`` file (its hex8 block is read).

    Returns
    -------
    BlockMesh
        The quarter block's mesh.

    Examples
    --------
    >>> import indentation_studio as ins
    >>> mesh = ins.forward.build_mesh(ins.ModelSpec())
    >>> mesh.nodes.shape[1], mesh.elements.shape[1]
    (3, 8)
    """
    if spec.mesh.feb_file:
        return read_feb_block_mesh(spec.mesh.feb_file)
    if spec.mesh.is_composite:
        return composite_mesh(spec.mesh.preset, spec.geometry, radius=spec.indenter.radius)
    if spec.mesh.preset in CONTACT_MESH_LEVELS:
        return contact_mesh(spec.mesh.preset, spec.indenter.radius, spec.geometry)
    return preset_mesh(spec.mesh.preset, spec.geometry)
