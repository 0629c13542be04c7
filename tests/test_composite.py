"""The composite phantom (paper 2.4.2, supplement S1): its mesh (fiber count, volume fraction,
conformity, element sets), its spec, and a two-material patch test of the solver's per-element
materials."""

import numpy as np
import pytest

import indentation_studio as ins
from indentation_studio.forward.composite_mesh import (
    FIBERS,
    MATRIX,
    PHANTOM,
    composite_mesh,
    fiber_volume_fraction,
)
from indentation_studio.forward.spec import (
    CompositeMaterial,
    Constituent,
    Geometry,
    ModelSpec,
    SpecError,
)


@pytest.fixture(scope="module")
def coarse():
    return composite_mesh("composite-coarse")


def _fiber_rectangles(geometry: Geometry | None = None) -> list[tuple[float, float, float, float]]:
    geometry = geometry or Geometry()
    s = PHANTOM.fiber_size / 2
    xs = [c for c in PHANTOM.x_centres(2 * geometry.half_x) if c > 0]
    zs = PHANTOM.z_centres(geometry.height)
    return [(x - s, x + s, z - s, z + s) for x in xs for z in zs]


def test_layout_of_s1():
    assert PHANTOM.fibers == 168
    assert PHANTOM.bottom_plate(60.0) == pytest.approx(60.0 - 14 * 4.17)
    assert PHANTOM.fiber_volume_fraction(100.0, 60.0) == pytest.approx(168 * 1.6**2 / 6000.0)
    assert PHANTOM.fiber_volume_fraction(100.0, 60.0) == pytest.approx(0.0717, abs=5e-5)
    x = PHANTOM.x_centres(100.0)
    assert np.allclose(x, -x[::-1]) and np.all(np.abs(x) > 0.8)  # symmetric, none on x = 0
    assert (x > 0).sum() == 6


def test_coarse_mesh_fiber_count_volume_fraction_and_sets(coarse):
    assert 2000 < coarse.n_nodes < 6000
    assert coarse.material_names == ("matrix", "fibers")
    assert set(np.unique(coarse.element_material)) == {MATRIX, FIBERS}
    assert fiber_volume_fraction(coarse) == pytest.approx(84 * 1.6**2 * 50.0 / (50 * 50 * 60), rel=1e-12)
    fib = coarse.element_set("fibers")
    assert np.array_equal(
        np.sort(np.concatenate([fib, coarse.element_set("matrix")])), np.arange(coarse.n_elements)
    )
    # every fiber element lies in exactly one fiber's cross-section: 84 fibers in the quarter
    X = coarse.nodes[coarse.elements[fib]]  # (nf, 8, 3)
    which = np.full(fib.size, -1)
    tol = 1e-9
    for r, (x0, x1, z0, z1) in enumerate(_fiber_rectangles()):
        inside = (
            (X[..., 0] >= x0 - tol).all(1)
            & (X[..., 0] <= x1 + tol).all(1)
            & (X[..., 2] >= z0 - tol).all(1)
            & (X[..., 2] <= z1 + tol).all(1)
        )
        assert not (inside & (which >= 0)).any()
        which[inside] = r
    assert (which >= 0).all()
    assert np.unique(which).size == 84


def test_mesh_conforms_to_every_fiber_boundary(coarse):
    x, z = np.unique(coarse.nodes[:, 0]), np.unique(coarse.nodes[:, 2])
    for x0, x1, z0, z1 in _fiber_rectangles():
        for v, grid in ((x0, x), (x1, x), (z0, z), (z1, z)):
            assert np.abs(grid - v).min() < 1e-9
    # no matrix element reaches into a fiber: matrix centroids lie outside every fiber
    c = coarse.nodes[coarse.elements[coarse.element_set("matrix")]].mean(axis=1)
    for x0, x1, z0, z1 in _fiber_rectangles():
        assert not ((c[:, 0] > x0) & (c[:, 0] < x1) & (c[:, 2] > z0) & (c[:, 2] < z1)).any()


def test_mesh_is_graded_towards_the_indenter(coarse):
    y = np.unique(coarse.nodes[:, 1])
    assert np.all(np.diff(np.diff(y)) > 0)


@pytest.mark.parametrize(("radius", "core"), [(4.77, 8.0), (8.0, 13.0)])
def test_the_composite_mesh_that_follows_the_contact_has_the_familys_core(radius, core):
    from indentation_studio.forward.composite_mesh import conforming_axis
    from indentation_studio.forward.spec import MeshChoice

    mesh = composite_mesh("composite-contact", radius=radius)
    assert mesh.source == f"composite:composite-contact-core{core:g}"
    y = np.unique(mesh.nodes[:, 1])
    inside = np.diff(y)[y[1:] <= core + 1e-9]
    # along the fibers (no boundaries to meet): uniform cells of at most 0.8 mm over the core
    # (a whole number of cells over the axis shrinks them a little), growing beyond it
    assert inside.size >= int(core / 0.8) and np.ptp(inside) < 1e-9 and 0.75 < inside[0] <= 0.8
    assert np.all(np.diff(np.diff(y)[y[:-1] >= core]) > 0)
    x = np.unique(mesh.nodes[:, 0])
    assert np.diff(x)[x[1:] <= core + 1e-9].max() <= 0.8 + 1e-9  # fibers cut cells, never enlarge them
    # the axis by itself: a 4 mm core of 0.5 mm cells, then h = 0.5 + 0.1 (t - 4): the integral
    # of 1/h over 20 mm is 8 + 10 ln 4.2 = 22.35, made 23 equal parts (0.486 mm in the core)
    t = conforming_axis(20.0, [], 1, 0.5, 0.1, core=4.0)
    assert t.size == 24 and np.allclose(np.diff(t)[:8], 0.5 * 22.3509 / 23, rtol=1e-4)
    mid = 0.5 * (t[1:] + t[:-1])
    assert np.allclose(np.diff(t)[9:], (0.5 + 0.1 * (mid[9:] - 4.0)) * 22.3509 / 23, rtol=0.02)
    choice = MeshChoice("composite-contact")
    assert choice.follows_contact and not MeshChoice("composite-medium").follows_contact
    assert ins.forward.spec.Contact().on_mesh(choice).integration == "surface"
    with pytest.raises(ValueError, match="needs the indenter's radius"):
        composite_mesh("composite-contact")


def test_paper_size_preset_is_near_the_papers_mesh():
    """2.4.2: 97,163 nodes and 86,400 hex8 in the paper's quarter."""
    mesh = composite_mesh("composite")
    assert (mesh.n_nodes, mesh.n_elements) == (93248, 86940)
    assert fiber_volume_fraction(mesh) == pytest.approx(0.07168, rel=1e-12)


def test_composite_spec_round_trips_and_homogeneous_specs_are_unchanged():
    spec = ModelSpec.composite_phantom("composite-coarse")
    d = spec.to_dict()
    assert d["composite"]["fibers"] == {
        "name": "fibers",
        "c1": -1227.0,
        "c2": 5945.0,
        "c5": 0.0,
        "kappa": 471800.0,
    }
    assert d["composite"]["matrix"]["kappa"] == pytest.approx(970.0)
    assert ModelSpec.from_dict(d) == spec
    assert "composite" not in ModelSpec().to_dict()
    assert spec.composite.fibers.shear_modulus == pytest.approx(9436.0)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"c1": float("nan")}, "composite.fibers.c1"),
        ({"c1": -6000.0}, "composite.fibers.c1"),
        ({"c5": -1.0}, "composite.fibers.c5"),
        ({"kappa": -5.0}, "composite.fibers.kappa"),
    ],
)
def test_bad_constituents_are_refused_by_name(kwargs, field):
    args = {"name": "fibers", "c1": -1227.0, "c2": 5945.0, **kwargs}
    with pytest.raises(SpecError, match=field.replace(".", r"\.")):
        Constituent(**args)


def test_composite_needs_a_composite_mesh_and_vice_versa():
    from indentation_studio.forward.spec import MeshChoice

    with pytest.raises(SpecError, match=r"mesh\.preset"):
        ModelSpec(composite=CompositeMaterial())
    with pytest.raises(SpecError, match=r"mesh\.preset"):
        ModelSpec(mesh=MeshChoice("composite-coarse"))


def test_composite_export_writes_two_materials_and_parts_and_reads_back(tmp_path, coarse):
    """The FEBio 4 export of the composite: one uncoupled Mooney-Rivlin material, hex8 part and
    solid domain per element set; read back, the element sets are the same elements."""
    import xml.etree.ElementTree as ET

    from indentation_studio.forward.feb_mesh import read_feb_block_mesh
    from indentation_studio.forward.febio.writer import write_feb
    from indentation_studio.forward.spec import MeshChoice

    spec = ModelSpec.composite_phantom("composite-coarse")
    path = write_feb(spec, tmp_path / "composite.feb", mesh=coarse)
    root = ET.parse(path).getroot()
    mats = {m.get("name"): m for m in root.iterfind("Material/material")}
    assert set(mats) == {"matrix", "fibers", "Indenter"}
    assert mats["Indenter"].get("id") == "2"
    for name, (c1, c2, k) in {"matrix": (9.7, 0.0, 970.0), "fibers": (-1227.0, 5945.0, 471800.0)}.items():
        m = mats[name]
        assert m.get("type") == "Mooney-Rivlin"
        assert [float(m.find(t).text) for t in ("c1", "c2", "k")] == [c1, c2, k]
    parts = [e.get("name") for e in root.iterfind("Mesh/Elements") if e.get("type") == "hex8"]
    assert parts == ["matrix", "fibers"]
    assert [(d.get("name"), d.get("mat")) for d in root.iterfind("MeshDomains/SolidDomain")] == [
        ("matrix", "matrix"),
        ("fibers", "fibers"),
    ]
    ids = [int(e.get("id")) for e in root.iterfind("Mesh/Elements/elem")]
    assert ids == list(range(1, len(ids) + 1))  # unique, consecutive through the parts

    back = read_feb_block_mesh(path)
    assert back.material_names == ("matrix", "fibers")
    assert np.array_equal(back.node_ids, coarse.node_ids) and np.allclose(back.nodes, coarse.nodes)
    for name in ("matrix", "fibers"):
        a = np.sort(np.sort(coarse.elements[coarse.element_set(name)], axis=1), axis=0)
        b = np.sort(np.sort(back.elements[back.element_set(name)], axis=1), axis=0)
        assert np.array_equal(a, b)
    # a spec on the read-back file is a composite again
    spec_back = ModelSpec(mesh=MeshChoice(feb_file=str(path)), composite=spec.composite)
    from indentation_studio.forward.element_moduli import element_moduli

    moduli = element_moduli(spec_back, back)
    assert np.count_nonzero(moduli.c2 == 5945.0) == coarse.element_set("fibers").size


def test_embedded_solver_runs_the_composite_with_per_element_materials(coarse):
    """The indentation solver on the phantom's coarse mesh: constituents equal to one material
    give that material's result to the last bit; the real fibers stiffen the block; the composite
    has no (c1, c5) sensitivities."""
    from indentation_studio.forward.solver import EmbeddedSolver
    from indentation_studio.forward.spec import Material, MeshChoice, Protocol

    protocol = Protocol(step_size=0.5, steps=2)
    same = CompositeMaterial(
        Constituent("matrix", 9.7, kappa=1000.0), Constituent("fibers", 9.7, kappa=1000.0)
    )
    spec = ModelSpec.composite_phantom("composite-coarse", composite=same, protocol=protocol)
    homogeneous = ModelSpec(
        material=Material(c1=9.7, c5=0.0, kappa=1000.0), mesh=MeshChoice("coarse"), protocol=protocol
    )
    # one thread each: the load-aware thread policy may give two runs different thread counts,
    # and bit-for-bit equality is asked of the arithmetic, not of PARDISO's threads
    a = EmbeddedSolver(spec, coarse).run(threads=1)
    b = EmbeddedSolver(homogeneous, coarse).run(threads=1)
    assert np.array_equal(a.force, b.force) and np.array_equal(a.displacement, b.displacement)
    assert a.spec["composite"]["fibers"]["c1"] == 9.7 and "composite" not in b.spec
    real = EmbeddedSolver(ModelSpec.composite_phantom("composite-coarse", protocol=protocol), coarse).run()
    assert real.force[-1] > 1.05 * a.force[-1]
    with pytest.raises(ValueError, match="composite"):
        EmbeddedSolver(spec, coarse).run(sensitivities=True)


def test_cli_composite_equibiaxial_json_and_figure(tmp_path):
    """``indent-studio composite equibiaxial --json``: the phantom's stresses, the eq. 10 fit and
    eq. 11 beside it; ``--figure`` writes Fig. 14."""
    import json

    from typer.testing import CliRunner

    from indentation_studio.studio.cli import app

    png = tmp_path / "fig14.png"
    args = ["composite", "equibiaxial", "--max-stretch", "1.02", "--steps", "2", "--cell", "2.0"]
    out = CliRunner().invoke(app, [*args, "--figure", str(png), "--json"])
    assert out.exit_code == 0, out.output
    d = json.loads(out.stdout)
    assert d["sigma_fiber_kPa"][-1] == pytest.approx(41.79, rel=1e-3)
    assert d["sigma_transverse_kPa"][-1] == pytest.approx(3.072, rel=1e-3)
    assert d["fit"]["values"]["c5"] == pytest.approx(1941.3, rel=1e-3)
    assert d["eq11"]["c5"] == pytest.approx(0.07168 * 4718 + (1 - 0.07168) * 9.7, rel=1e-9)
    assert png.is_file() and png.stat().st_size > 1000
    bad = CliRunner().invoke(app, [*args[:2], "--max-stretch", "0.9", "--json"])
    assert bad.exit_code != 0 and "max_stretch" in json.loads(bad.stdout)["error"]
    # the command is one call of the library, which a notebook reaches as ins.design
    import indentation_studio as ins

    done = ins.design.composite_equibiaxial_fit(1.02, 2, 2.0)
    assert done.fit.values == pytest.approx(d["fit"]["values"], rel=1e-6)  # threads: 4e-9 seen
    assert "not a 95 % bound" in d["fit"]["std_errors_include"]


def test_equibiaxial_figure_draws_points_and_eq10():
    from indentation_studio.studio.figures import equibiaxial_figure

    lam = np.array([1.0, 1.1, 1.2])
    fig = equibiaxial_figure(lam, [0.0, 100.0, 190.0], [0.0, 12.0, 23.0], {"c1": 12.0, "c5": 1500.0})
    lines = fig.axes[0].get_lines()
    assert len(lines) == 4
    assert lines[2].get_ydata()[-1] == pytest.approx(2 * 12.0 * (1.2**2 - 1.2**-4) + 1500.0 * 0.2)


def test_equibiaxial_fiber_stress_is_the_parallel_fiber_rule_of_mixtures():
    """Along continuous bonded fibers the FE composite's averaged stress is the constituents'
    own stresses mixed by volume (fibers in uniaxial tension, matrix equibiaxial), to within the
    small lateral interaction; that is what puts eq. 10's c5 near FVF x 6 (c1_f + c2_f), not
    eq. 11b's FVF x (c1_f + c2_f)."""
    from indentation_studio.design.constituents import parallel_fiber_stresses

    done = ins.design.composite_equibiaxial_fit(1.2, 4, 2.0)
    lam = done.stretch.stretch_x[1:]
    fvf = done.fiber_volume_fraction
    s11, s22 = parallel_fiber_stresses(lam, 19.4, -1227.0, 5945.0, fvf)
    # by hand at lambda = 1.2: fibers 2 (c1 + c2 / 1.2)(1.44 - 1 / 1.2), matrix 19.4 (1.44 - 1.2^-4)
    fib = 2 * (-1227 + 5945 / 1.2) * (1.44 - 1 / 1.2)
    mat = 19.4 * (1.44 - 1.2**-4)
    assert s11[-1] == pytest.approx(fvf * fib + (1 - fvf) * mat, rel=1e-12)
    assert s22[-1] == pytest.approx(mat, rel=1e-12)
    gap = np.abs(done.stretch.sigma_fiber[1:] / s11 - 1.0)
    assert gap.max() < 0.03
    par = done.parallel_fibers()
    assert par["fe_fiber_stress_max_rel_gap"] == pytest.approx(gap.max(), rel=1e-12)
    assert par["small_strain_c5"] == pytest.approx(fvf * (6 * 4718 - 6 * 19.4), rel=1e-12)
    assert done.fit.values["c5"] > 3 * done.eq11[1]
