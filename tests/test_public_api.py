"""The public API: every name in a subpackage's ``__all__`` resolves, none shadows a submodule of
the same package (which the import system would set over it), and ``ins.*`` reaches the workflows."""

from __future__ import annotations

import importlib
import pkgutil

import pytest

import indentation_studio as ins

PACKAGES = ["forward", "campaign", "surrogate", "design", "inference", "studio"]


@pytest.mark.parametrize("name", PACKAGES)
def test_every_exported_name_resolves_and_shadows_no_submodule(name):
    package = importlib.import_module(f"indentation_studio.{name}")
    submodules = {m.name for m in pkgutil.iter_modules(package.__path__)}
    assert package.__all__, name
    for exported in package.__all__:
        assert getattr(package, exported) is not None
        assert exported not in submodules - {"figures", "febio", "lab"}, (
            f"{name}.{exported} is also a submodule"
        )


def test_top_level_reaches_the_everyday_workflows():
    for exported in (
        "simulate",
        "run_named_campaign",
        "train_surrogate",
        "fit_experiment",
        "sample_posterior_for",
    ):
        assert callable(getattr(ins, exported))
    assert callable(ins.figures.corner_figure) and isinstance(ins.__version__, str)


def test_model_error_is_reachable_from_a_notebook():
    """The error budget, what it leaves for a mesh, and the words a bound says it holds."""
    left = ins.shipped_budget(ins.ModelSpec())  # the paper's test on 'default'
    assert left["source"]["model"] == "default" and left["c5_pct"] > 20
    assert callable(ins.surrogate.remaining_bias) and callable(ins.surrogate.surrogate_error_budget)
    assert "hold no model error" in ins.inference.model_error_scope(None)
    assert callable(ins.inference.combined_pct) and callable(ins.forward.thread_limits)
    at = ins.surrogate.budget_at(left, [11.0, 330.0])  # a budget against one finer mesh: its largest value
    assert at["c5_pct"] == left["c5_pct"] and at["source"]["where"] == "largest"
    assert callable(ins.forward.termination_as_interrupt) and ins.forward.MeshFamily().cells(4) == (41, 41)
    # the meshes that follow the contact: by name in a spec, or by radius
    assert ins.forward.contact_family(8.0).core_xy == 13.0
    assert ins.forward.contact_mesh("contact-L1", 4.77).n_nodes == 2197


def test_friction_is_reachable_from_a_notebook():
    """The contact in a spec, as a parameter, in the error budget and in the words of a bound."""
    spec = ins.ModelSpec().with_friction(0.3)
    assert spec.contact == ins.forward.Contact(friction=0.3).on_mesh(spec.mesh)  # node by node on default
    assert spec.contact.integration == "node"
    assert spec.with_parameters(mu=1.0).contact.friction == 1.0
    stick, _ = ins.inference.resolve_model("coarse@stick", spec)
    assert stick.predictor.spec.contact.friction is None
    assert "Coulomb friction mu = 0.3 assumed" in ins.inference.model_error_scope(
        None, contact=spec.contact.describe()
    )
    assert callable(ins.forward.contact_response) and callable(ins.forward.tributary_areas)
    # the shipped budget was measured with the perfect stick: it is not a frictional model's
    assert ins.shipped_budget(ins.ModelSpec()) is not None and ins.shipped_budget(spec) is None
