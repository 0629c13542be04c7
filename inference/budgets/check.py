"""Whether a fit's test has an error budget: without one its bounds hold no model error, and the
fit says so loudly (the CLI's text output and the report, not only a sentence in fit.json).

A test is the indenter's radius, the protocol (steps and depth), the contact and the DIC field
of view. A budget is known when the surrogate carries one (measured for its mesh and this test,
given at training, or shipped with the studio: :func:`surrogate.error_budgets.shipped_budget`), or
when the fit carries its mesh check (``--check-mesh``: the finer mesh's GCI in its bounds). A
budget measured over a field of view much wider or narrower than the data's
(``FOV_TOLERANCE``) is named as not quite this test, and a fit outside the points its budget was
measured at is told that its budget there is not measured.
"""

from __future__ import annotations

import numpy as np

from ...forward.mesh_presets import CONTACT_CORE_PER_RADIUS

__all__ = ["FOV_TOLERANCE", "HOW_TO_MEASURE", "OUTSIDE_HOW", "budget_status", "how_to_measure"]

#: A budget measured over a field of view whose radius differs from the data's by more than
#: this fraction is not this test's.
FOV_TOLERANCE = 0.2

#: How to measure a budget for a new test (docs: Fit and posterior, "No error budget"); {core}
#: is the contact family's core at the test's radius, {radius} the radius.
HOW_TO_MEASURE = (
    "measure one: a verification study of the meshes that follow the contact at this test "
    "(indent-studio verification-study --family 8x8:1.2:1.5:core{core} --levels 0,1,2,3 "
    "--points 3:120,3:330,3:540,11:120,11:330,11:540,19:120,19:330,19:540 --radii {radius} --substeps 1 "
    "--contact surface --contact-order 1 --out-dir runs/verification-R{radius}, with this test's protocol), "
    "then indent-studio design study-budget --study runs/verification-R{radius} --out budget.json, and "
    "train the surrogate on a contact-L1 campaign with --error-budget budget.json (docs: Fit and posterior, "
    "'No error budget')"
)


#: What to add to :data:`HOW_TO_MEASURE` for a fit outside its budget's points.
OUTSIDE_HOW = "add this point ({c1:.3g}:{c5:.4g}) to the study's points and "


def how_to_measure(radius: float) -> str:
    """:data:`HOW_TO_MEASURE` for a sphere of ``radius`` mm."""
    core = max(1, round(CONTACT_CORE_PER_RADIUS * radius))
    return HOW_TO_MEASURE.format(core=core, radius=f"{radius:g}")


def _test(spec, fov_mm: float) -> str:
    """The test in words: radius, protocol, contact, field of view."""
    p = spec.protocol
    return (
        f"R = {spec.indenter.radius:g} mm, {p.steps} x {p.step_size:g} mm to {p.steps * p.step_size:g} mm, "
        f"{spec.contact.describe()}, field of view {fov_mm:.3g} mm"
    )


def budget_status(result) -> dict:
    """Whether the fit (an :class:`inference.fit.result.ExperimentFit`) has an error budget
    for its test: ``{"known": bool, "test": str, "source": dict | None, "warning": str | None}``;
    the warning says what the bounds then hold and how to measure one (a fit outside its budget's
    points is told so with ``known`` True)."""
    inputs = result.inputs
    xyz = np.asarray(inputs.dic.xyz, float)
    fov = float(np.hypot(xyz[:, 0], xyz[:, 1]).max()) if len(xyz) else float("nan")
    test = _test(inputs.spec, fov)
    model = result.model_error
    source = None if model is None else model.budget_source
    if result.mesh_check is not None:
        return {"known": True, "test": test, "source": {"mesh_check": result.check_mesh}, "warning": None}
    if source is None:
        mesh = (inputs.spec.to_dict().get("mesh") or {}).get("preset") or "its mesh"
        return {
            "known": False,
            "test": test,
            "source": None,
            "warning": (
                f"no error budget is known for this test ({test}) on the surrogate's mesh ({mesh}): "
                "the bounds hold measurement noise only, no model error, and can miss the truth by many "
                "times their width (the 'default' mesh alone put c5 up to 24 % off at the paper's test); "
                + how_to_measure(inputs.spec.indenter.radius)
            ),
        }
    budget_fov = source.get("field_of_view_mm") if isinstance(source, dict) else None
    if budget_fov and np.isfinite(fov) and abs(fov / float(budget_fov) - 1.0) > FOV_TOLERANCE:
        return {
            "known": False,
            "test": test,
            "source": source,
            "warning": (
                f"the error budget in these bounds was measured over a {float(budget_fov):g} mm field of view; "
                f"these data cover {fov:.3g} mm ({test}): it may not hold here; "
                + how_to_measure(inputs.spec.indenter.radius)
            ),
        }
    if isinstance(source, dict) and source.get("where") == "outside":
        at = source.get("at") or [float("nan")] * 2
        return {
            "known": True,
            "test": test,
            "source": source,
            "warning": (
                f"the fit ({at[0]:.3g}, {at[1]:.4g} kPa) lies outside the region its error budget verified "
                f"(the {source.get('points')} test points of {source.get('file')}): the budget there is its "
                "nearest points' largest, not measured, and can be far too narrow (at R = 8 mm, {1.5, 560} kPa, "
                "made on contact-L4, level 3's c5 missed level 4's by 6.4 % with mu held where the nearest "
                "point's correction was 0.8 %); "
                + OUTSIDE_HOW.format(c1=at[0], c5=at[1])
                + how_to_measure(inputs.spec.indenter.radius)
            ),
        }
    return {"known": True, "test": test, "source": source, "warning": None}
