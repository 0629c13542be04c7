"""The high fidelity's field error as a variance of the adequacy test (inference.adequacy.field_error):
the table is the band-wise root mean square of the fine field less the coarse one (the largest over
the pairs), looked up by a node's band and a step's depth; the shipped tables are found for the
shipped surrogates' test and mesh, and for no other."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from indentation_studio.inference.adequacy.field_error import (
    BAND_R,
    field_error_table,
    field_variance,
    shipped_field_error,
)
from indentation_studio.surrogate.shipped import load_shipped, shipped_surrogates

R = 4.0


def _run(n: int, field, depths=(0.0, 0.5, 1.0)) -> SimpleNamespace:
    """A run on an n x n top grid over [0, 25]^2 mm whose top field at each depth is field(x, y, depth)."""
    g = np.linspace(0.0, 25.0, n)
    x, y = (a.ravel() for a in np.meshgrid(g, g, indexing="ij"))
    top = np.column_stack([x, y, np.full_like(x, 60.0)])
    return SimpleNamespace(
        depth=np.asarray(depths), top_xyz=top, displacement=np.stack([field(x, y, d) for d in depths])
    )


def _inside(x, y, d, value):
    """value (ux, uy, uz) times the depth within R of the axis, nothing outside."""
    near = (np.hypot(x, y) < R)[:, None]
    return np.where(near, np.asarray(value) * d, 0.0)


def test_the_table_is_the_band_rms_of_the_fine_less_the_coarse_field_the_largest_over_pairs():
    # the coarse level's field is 0 (its interpolant too); the fine one is a value near the axis
    coarse = _run(6, lambda x, y, d: np.zeros((x.size, 3)))
    a = _run(51, lambda x, y, d: _inside(x, y, d, (0.02, 0.0, 0.1)))
    b = _run(51, lambda x, y, d: _inside(x, y, d, (0.01, 0.03, 0.0)))
    table = field_error_table([(coarse, a), (coarse, b)], R)
    rms = np.asarray(table["rms_mm"])
    assert table["depths"] == [0.5, 1.0] and rms.shape == (2, 41, 3)
    # bands 0 to 3 lie within R: each node there carries the value; the largest of the two pairs
    np.testing.assert_allclose(rms[1, :4], np.tile([0.02, 0.03, 0.1], (4, 1)), rtol=1e-12)
    np.testing.assert_allclose(rms[0, :4], np.tile([0.01, 0.015, 0.05], (4, 1)), rtol=1e-12)
    assert np.all(rms[:, 5:] == 0.0)  # beyond R and its band's edge: nothing
    # a node's variance is its band's rms squared at that depth
    nodes = np.array([[1.0, 1.0], [0.0, 2.9], [20.0, 3.0]])
    v = field_variance(table, nodes, np.array([1.0, 0.5]))
    assert v.shape == (2, 3, 3)
    np.testing.assert_allclose(v[0, :2], np.tile(np.square([0.02, 0.03, 0.1]), (2, 1)), rtol=1e-12)
    assert np.all(v[:, 2] == 0.0) and BAND_R * R == 1.0
    with pytest.raises(ValueError, match="not all among the table's"):
        field_variance(table, nodes, np.array([0.75]))
    with pytest.raises(ValueError, match="do not share their depths"):
        field_error_table([(coarse, _run(11, lambda x, y, d: np.zeros((x.size, 3)), depths=(0.0, 0.5)))], R)


@pytest.mark.slow
def test_the_shipped_tables_belong_to_the_shipped_surrogates_test_and_mesh():
    """Each shipped multi-fidelity surrogate's high fidelity (contact-L3, the surface stick) has its
    table against contact-L4; another mesh, contact or protocol has none."""
    for entry in shipped_surrogates():
        model = load_shipped(entry).meta["campaign"]["model"]
        table = shipped_field_error(model, model["mesh"]["preset"])
        assert (
            table is not None and table["coarse_mesh"] == "contact-L3" and table["fine_mesh"] == "contact-L4"
        )
        assert table["radius"] == model["indenter"]["radius"] and len(table["depths"]) == 28
        assert shipped_field_error(model, "contact-L1") is None
        other = {**model, "contact": {**model["contact"], "friction": 0.3}}
        assert shipped_field_error(other, "contact-L3") is None
        shallow = {**model, "protocol": {**model["protocol"], "steps": 20}}
        assert shipped_field_error(shallow, "contact-L3") is None
