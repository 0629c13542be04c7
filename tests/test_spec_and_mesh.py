"""Model spec validation and the graded block meshes."""

import math

import numpy as np
import pytest

from indentation_studio.forward.feb_mesh import FebMeshError, read_feb_block_mesh
from indentation_studio.forward.febio.writer import write_feb
from indentation_studio.forward.mesh import MESH_PRESETS, build_mesh, preset_mesh
from indentation_studio.forward.spec import (
    Contact,
    Indenter,
    Material,
    MeshChoice,
    ModelSpec,
    Protocol,
    SolverOptions,
    SpecError,
)
from indentation_studio.studio.verification_cli import parse_family


@pytest.mark.parametrize(
    ("build", "field"),
    [
        (lambda: Material(c1=-1.0), "material.c1"),
        (lambda: Material(c1=math.nan), "material.c1"),
        (lambda: Material(c5=math.inf), "material.c5"),
        (lambda: Material(kappa=0.0), "material.kappa"),
        (lambda: Material(fiber=(0.0, 0.0, 0.0)), "material.fiber"),
        (lambda: Indenter(radius=0.0), "indenter.radius"),
        (lambda: Indenter(radius=-4.77), "indenter.radius"),
        (lambda: Protocol(step_size=0.5, steps=0), "protocol.steps"),
        (lambda: ModelSpec(protocol=Protocol(step_size=1.0, steps=40)), "protocol.steps"),
        (lambda: SolverOptions(fiber_stretch="centre"), "solver.fiber_stretch"),
    ],
)
def test_bad_spec_names_the_field(build, field):
    with pytest.raises(SpecError) as info:
        build()
    assert info.value.field == field
    assert field in str(info.value)


def test_spec_round_trips_and_normalises_fiber():
    spec = ModelSpec(material=Material(c1=12.0, c5=250.0, fiber=(0.0, 2.0, 0.0)))
    assert spec.material.fiber == (0.0, 1.0, 0.0)
    assert ModelSpec.from_dict(spec.to_dict()) == spec
    assert Indenter.preset("large").radius == 8.0
    assert spec.protocol.max_depth == 14.0


def test_each_mesh_has_its_own_default_contact():
    """The contact-L meshes (the fit's model) take the surface stick with one point per face; every
    other mesh the node-wise stick, written as before; a contact said aloud is kept on any mesh."""
    paper = ModelSpec()
    assert (paper.contact.integration, paper.contact.order) == ("node", 2)
    assert "contact" not in paper.to_dict()  # as files written before the surface contact read
    for level in ("contact-L0", "contact-L1", "contact-L4"):
        spec = ModelSpec(mesh=MeshChoice(level))
        assert (spec.contact.integration, spec.contact.order, spec.contact.friction) == ("surface", 1, None)
        assert spec.to_dict()["contact"] == {
            "friction": None,
            "penalty": 1e5,
            "integration": "surface",
            "order": 1,
        }
        assert ModelSpec.from_dict(spec.to_dict()) == spec
        assert spec.with_friction(0.3).contact.integration == "surface"
    node = ModelSpec(mesh=MeshChoice("contact-L1"), contact=Contact(integration="node"))
    assert node.contact.integration == "node" and ModelSpec.from_dict(node.to_dict()) == node
    surface2 = ModelSpec(contact=Contact(integration="surface"))  # the order of a preset mesh: 2
    assert surface2.contact.order == 2 and ModelSpec.from_dict(surface2.to_dict()) == surface2
    assert Contact().describe() == "perfect stick"
    assert (
        ModelSpec(mesh=MeshChoice("contact-L1")).contact.describe()
        == "stick by penalty, surface-integrated (1x1 per face)"
    )


def test_element_mean_fiber_is_written_only_where_chosen(tmp_path):
    """The Gauss points' fiber (FEBio's) leaves the spec's plain data as it was before the option
    existed; the element mean round-trips, and FEBio, which has no such element, refuses it."""
    assert "fiber_stretch" not in ModelSpec().to_dict()["solver"]
    mean = ModelSpec(solver=SolverOptions(fiber_stretch="mean"))
    assert mean.to_dict()["solver"]["fiber_stretch"] == "mean"
    assert ModelSpec.from_dict(mean.to_dict()) == mean
    with pytest.raises(ValueError, match="fiber_stretch"):
        write_feb(mean, tmp_path / "m.feb")


@pytest.mark.parametrize("name", sorted(MESH_PRESETS))
def test_preset_meshes_are_valid_quarter_blocks(name):
    mesh = preset_mesh(name)
    assert mesh.n_nodes == MESH_PRESETS[name].node_count()
    assert np.allclose(mesh.nodes.min(axis=0), [0, 0, 0])
    assert np.allclose(mesh.nodes.max(axis=0), [50, 50, 60])
    assert np.all(mesh.nodes[mesh.top, 2] == 60.0)
    assert np.all(mesh.nodes[mesh.xsym, 0] == 0.0)
    # graded toward (0, 0, 60): the smallest cell touches the indentation point
    x = np.unique(mesh.nodes[:, 0])
    assert np.diff(x)[0] == pytest.approx(np.diff(x).min())
    if name == "reference":
        assert 25_000 <= mesh.n_nodes <= 30_000


def test_febio_block_mesh_is_read_and_default_preset_reproduces_it(febio_baseline):
    feb = read_feb_block_mesh(febio_baseline / "baseline.feb")
    assert (feb.n_nodes, feb.n_elements, feb.top.size) == (1452, 1100, 121)
    ref = np.load(febio_baseline / "baseline.npz")
    assert np.array_equal(feb.node_ids[feb.top], ref["top_ids"])
    assert np.allclose(feb.nodes[feb.top], ref["top_xyz0"], atol=1e-8)
    ours = preset_mesh("default")
    assert np.allclose(ours.nodes, feb.nodes, atol=1e-7)
    assert np.array_equal(ours.elements, feb.elements)


def test_malformed_feb_is_named(tmp_path):
    bad = tmp_path / "bad.feb"
    bad.write_text("<febio_spec><Mesh><Nodes><node id='1'>0,0</node></Nodes></Mesh></febio_spec>")
    with pytest.raises(FebMeshError, match=r"bad\.feb"):
        read_feb_block_mesh(bad)
    with pytest.raises(FebMeshError, match="no such file"):
        read_feb_block_mesh(tmp_path / "missing.feb")


@pytest.mark.parametrize("structured", [True, False])
def test_top_field_interpolator_reproduces_linear_fields(structured: bool) -> None:
    """The reference field at other nodes (eq. 1b's interpolation): exact for a linear field on
    a tensor-grid top (bilinear) and on a scattered one (a Cubit-like mesh read from a .feb)."""
    from indentation_studio.forward.convergence.mesh_study import top_field_interpolator

    rng = np.random.default_rng(3)
    if structured:
        g = np.concatenate([[0.0], np.cumsum(rng.uniform(0.5, 3.0, 12))])
        g *= 50.0 / g[-1]
        xy = np.stack(np.meshgrid(g, g, indexing="ij"), axis=-1).reshape(-1, 2)
    else:
        edge = np.linspace(0.0, 50.0, 9)
        border = np.concatenate(
            [
                np.stack([edge, 0 * edge], 1),
                np.stack([edge, 0 * edge + 50], 1),
                np.stack([0 * edge, edge], 1),
                np.stack([0 * edge + 50, edge], 1),
            ]
        )
        xy = np.concatenate([border, rng.uniform(0.0, 50.0, (200, 2))])
    field = np.stack(
        [1.0 + 0.2 * xy[:, 0] - 0.1 * xy[:, 1], 0.05 * xy[:, 1], -3.0 + 0.01 * xy.sum(1)], axis=1
    )
    at = top_field_interpolator(np.column_stack([xy, np.full(len(xy), 60.0)]), field[:, None, :])
    q = rng.uniform(0.0, 50.0, (300, 2))
    expect = np.stack([1.0 + 0.2 * q[:, 0] - 0.1 * q[:, 1], 0.05 * q[:, 1], -3.0 + 0.01 * q.sum(1)], axis=1)
    got = at(np.concatenate([q, [[60.0, -5.0]]]))  # a point off the block is clipped onto it
    assert got.shape == (301, 1, 3)
    np.testing.assert_allclose(got[:-1, 0], expect, atol=1e-10)
    np.testing.assert_allclose(got[-1, 0], [1.0 + 10.0, 0.0, -3.0 + 0.5], atol=1e-10)


@pytest.mark.parametrize(("radius", "family"), [(4.77, "8x8:1.2:1.5:core8"), (8.0, "8x8:1.2:1.5:core13x0.5")])
def test_contact_presets_are_the_verification_families_levels(radius, family):
    """``contact-Lk`` is level k of the family the verification study measured at that radius
    (docs/validation/verification.md), node for node; its uniform core holds every material point
    the sphere touches (1.36 R at R = 4.77, 1.21 R at R = 8, measured at 14 mm)."""
    for level in (1, 2):
        spec = ModelSpec(mesh=MeshChoice(f"contact-L{level}"), indenter=Indenter(radius))
        mesh = build_mesh(spec)
        np.testing.assert_array_equal(mesh.nodes, parse_family(family).mesh(level).nodes)
        assert mesh.source == f"preset:contact-L{level}@R{radius:g}"
    x = np.unique(mesh.nodes[mesh.top, 0])
    core = x[x <= 1.65 * radius + 0.5]
    assert core[-1] >= 1.36 * radius + 1.0  # the touched region and a margin of uniform cells
    np.testing.assert_allclose(np.diff(core), np.diff(core)[0])  # uniform
    # a store's mesh record differs between radii: the same preset name is never reused across them
    other = build_mesh(ModelSpec(mesh=MeshChoice("contact-L2"), indenter=Indenter(12.5 - radius)))
    assert other.geometry_record()["sha256"] != mesh.geometry_record()["sha256"]
