"""Structured hex8 quarter-block meshes graded toward the indentation point (paper 2.4.1).

The block spans x in [0, half_x], y in [0, half_y], z in [0, height]; the indenter touches
(0, 0, height). Cells are uniform (size ``h0``) in a core around the indentation point and
then grow geometrically to the far faces. Node numbering follows the FEBio files of
FEBio's baseline input (id = 1 + k + nz * (j + ny * i) for grid x[i], y[j], z[k]), so that node ids
of our meshes and of FEBio's coincide when the grids do.
"""

from __future__ import annotations

from .block_mesh import BlockMesh, grid_block
from .composite_mesh import composite_mesh
from .feb_mesh import read_feb_block_mesh
from .mesh_presets import MESH_PRESETS, GradedAxis, MeshPreset
from .spec import Geometry, ModelSpec

__all__ = [
    "MESH_PRESETS",
    "BlockMesh",
    "GradedAxis",
    "MeshPreset",
    "build_mesh",
    "grid_block",
    "preset_mesh",
    "structured_block",
]


def structured_block(geometry: Geometry, preset: MeshPreset, name: str = "custom") -> BlockMesh:
    """The graded structured hex8 mesh of the quarter block for ``preset``."""
    x = preset.xy.coordinates(geometry.half_x)
    y = preset.xy.coordinates(geometry.half_y)
    z = geometry.height - preset.z.coordinates(geometry.height)[::-1]
    return grid_block(x, y, z, f"preset:{name}")


def preset_mesh(name: str, geometry: Geometry | None = None) -> BlockMesh:
    """The named preset mesh of :data:`MESH_PRESETS`."""
    if name not in MESH_PRESETS:
        raise ValueError(f"unknown mesh preset {name!r}; use one of {sorted(MESH_PRESETS)}")
    return structured_block(geometry or Geometry(), MESH_PRESETS[name], name)


def build_mesh(spec: ModelSpec) -> BlockMesh:
    """The block mesh a spec asks for: a preset (of the composite phantom too), or the hex8 block
    of a FEBio file."""
    if spec.mesh.feb_file:
        return read_feb_block_mesh(spec.mesh.feb_file)
    if spec.mesh.is_composite:
        return composite_mesh(spec.mesh.preset, spec.geometry)
    return preset_mesh(spec.mesh.preset, spec.geometry)
