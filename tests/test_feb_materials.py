"""Every .feb the studio writes lists its materials as FEBio 4 reads them: ids 1, 2, ..., n in
order (FEBio refused the composite whose rigid indenter, id 2, came before the matrix, id 1),
each domain and rigid body naming a material that is there."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest

from indentation_studio.forward.febio.writer import check_material_ids, write_feb
from indentation_studio.forward.spec import MeshChoice, ModelSpec, Protocol


def _materials(path):
    root = ET.parse(path).getroot()
    check_material_ids(root)
    return root, [
        (int(m.get("id")), m.get("name"), m.get("type")) for m in root.iterfind("Material/material")
    ]


@pytest.mark.parametrize(
    "spec",
    [
        ModelSpec(mesh=MeshChoice("coarse"), protocol=Protocol(step_size=0.5, steps=2)),
        ModelSpec.composite_phantom("composite-coarse"),
    ],
    ids=["block", "composite"],
)
def test_written_feb_lists_materials_in_id_order(spec, tmp_path):
    path = write_feb(spec, tmp_path / "model.feb")
    root, mats = _materials(path)
    assert [m[0] for m in mats] == list(range(1, len(mats) + 1))
    rigid = [m for m in mats if m[2] == "rigid body"]
    assert [r[0] for r in rigid] == [2]
    assert {rb.text for rb in root.iter("rb")} == {"2"}
    if spec.composite is not None:
        assert [m[1] for m in mats] == ["matrix", "Indenter", "fibers"]
    text = path.read_text(encoding="ISO-8859-1")
    assert text.index('id="1"', text.index("<Material>")) < text.index('id="2"', text.index("<Material>"))


def test_check_refuses_materials_out_of_order(tmp_path):
    path = write_feb(ModelSpec.composite_phantom("composite-coarse"), tmp_path / "c.feb")
    root = ET.parse(path).getroot()
    mats = root.find("Material")
    mats[:] = sorted(mats, key=lambda m: -int(m.get("id")))
    with pytest.raises(ValueError, match=r"ids 1..3 in order, got \[3, 2, 1\]"):
        check_material_ids(root)
