"""Read the hex8 block mesh of a FEBio ``.feb`` file, so the solver runs on exactly FEBio's mesh."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from .block_mesh import BlockMesh


class FebMeshError(ValueError):
    """A ``.feb`` file whose block mesh cannot be read; the message names the file and the problem."""


def read_feb_block_mesh(path: str | Path) -> BlockMesh:
    """Nodes and hex8 elements of the block in a FEBio 4 ``.feb`` file.

    Only nodes referenced by ``hex8`` elements are kept (the indenter's shells are dropped);
    FEBio's node ids are kept in ``node_ids``. Node sets are derived from the coordinates. A file
    with several hex8 parts (the composite phantom, 2.4.2) gives a mesh with one element set per
    part, named after it (``BlockMesh.element_material``, ``material_names``).
    """
    path = Path(path)
    if not path.is_file():
        raise FebMeshError(f"{path}: no such file")
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise FebMeshError(f"{path}: not well-formed XML ({exc})") from exc
    mesh = root.find("Mesh")
    if mesh is None:
        raise FebMeshError(f"{path}: no <Mesh> section (FEBio 4 format expected)")

    coords: dict[int, tuple[float, float, float]] = {}
    for node in mesh.iterfind("Nodes/node"):
        try:
            xyz = tuple(float(v) for v in (node.text or "").split(","))
            coords[int(node.attrib["id"])] = xyz  # type: ignore[assignment]
        except (KeyError, ValueError) as exc:
            raise FebMeshError(f"{path}: malformed <node> {ET.tostring(node)[:80]!r}") from exc
        if len(xyz) != 3:
            raise FebMeshError(f"{path}: node {node.attrib.get('id')} has {len(xyz)} coordinates")

    conn: list[list[int]] = []
    part_of: list[int] = []
    parts: list[str] = []
    for block in mesh.iterfind("Elements"):
        if block.attrib.get("type") != "hex8":
            continue
        parts.append(block.attrib.get("name", f"part{len(parts) + 1}"))
        for elem in block.iterfind("elem"):
            part_of.append(len(parts) - 1)
            try:
                ids = [int(v) for v in (elem.text or "").split(",")]
            except ValueError as exc:
                raise FebMeshError(f"{path}: malformed hex8 element {elem.attrib.get('id')}") from exc
            if len(ids) != 8:
                raise FebMeshError(f"{path}: hex8 element {elem.attrib.get('id')} has {len(ids)} nodes")
            conn.append(ids)
    if not conn:
        raise FebMeshError(f"{path}: no hex8 elements")

    ext = np.asarray(conn, dtype=np.int64)
    node_ids = np.unique(ext)
    missing = [i for i in node_ids if i not in coords]
    if missing:
        raise FebMeshError(f"{path}: hex8 elements refer to undefined nodes {missing[:5]}")
    nodes = np.array([coords[int(i)] for i in node_ids])
    elements = np.searchsorted(node_ids, ext)
    sets: dict = {}
    if len(parts) > 1:
        if len(set(parts)) != len(parts):
            raise FebMeshError(f"{path}: hex8 parts share a name ({parts})")
        sets = {"element_material": np.asarray(part_of), "material_names": tuple(parts)}
    try:
        return BlockMesh.from_arrays(nodes, elements, node_ids, f"feb:{path}", **sets)
    except ValueError as exc:
        raise FebMeshError(str(exc)) from exc
