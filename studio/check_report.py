"""The data-check report (``indent-studio check``): the numbers of
:func:`inference.experiment.data_check.check_experiment` as ``check.json`` and one HTML page with the
figures of :mod:`.check_figures` beside it."""

from __future__ import annotations

import html
import io
from pathlib import Path

from ..atomic_write import atomic_write, atomic_write_json
from ..inference.experiment.data import load_experiment
from ..inference.experiment.data_check import check_experiment
from ..inference.experiment.processing import to_model_frame
from .check_figures import dic_coverage_figure, hold_fits_figure, registration_figure, sphere_fit_figure

FIGURES = (
    ("holds.png", "Force during each hold with its eq. 9 fit and f_inf, and the fit's residual."),
    (
        "coverage.png",
        "DIC points per step in the model frame, the indenter's contact radius and the field of view.",
    ),
    ("sphere.png", "The indenter points against the fitted sphere, and the residual beside the DIC noise."),
    (
        "registration.png",
        "The indentation point and fiber direction on the top face (the DIC frame leveled); FE top nodes with "
        "data and obscured.",
    ),
)


def _png(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    return buf.getvalue()


def _rows(items: list[dict], columns: list[tuple[str, str]]) -> str:
    head = "".join(f"<th>{html.escape(label)}</th>" for _, label in columns)
    body = "".join(
        "<tr>" + "".join(f"<td>{_fmt(r[key])}</td>" for key, _ in columns) + "</tr>" for r in items
    )
    return f"<table><tr>{head}</tr>{body}</table>"


def _fmt(v) -> str:
    return html.escape(f"{v:.4g}" if isinstance(v, float) else str(v))


def _face(reg: dict, signature: float | None) -> str:
    """The top face the registration found in the DIC data, and the field's indentation."""
    if "tilt_deg" not in reg:
        return ""
    sink = (
        ""
        if signature is None
        else f" At the deepest step the surface beside the indenter sinks {-signature:.3g} mm below the far field."
    )
    return (
        f"<p>Top face (the plane of the DIC reference positions): normal {_fmt([round(v, 4) for v in reg['surface_normal']])}, "
        f"tilted {reg['tilt_deg']:.3g} deg from the DIC z (leveled for the model frame); the points' spread about it "
        f"{reg['surface_rms_mm']:.3g} mm RMS; the indentation point {reg['indentation_point_off_surface_mm']:+.3g} mm from "
        f"it.{sink}</p>"
    )


def fiber_text(exp, check) -> str:
    """The fiber direction in the frame it was typed in (the DIC frame, ``--fiber-angle``) and in
    the leveled frame the model works in, each named; and the strain field's."""
    strain = check.fiber_angle_from_strain_deg
    said = "" if strain is None else f"; the strain field says {strain:.2f} deg in the leveled frame"
    if check.fiber_angle_estimated:
        return f"Fiber direction estimated from the strain field: {check.fiber_angle_deg:.2f} deg in the leveled frame{said}."
    return (
        f"Fiber direction {exp.fiber_angle_deg:.2f} deg in the DIC frame (declared: experiment.json, --fiber-angle), "
        f"{check.fiber_angle_deg:.2f} deg in the leveled frame (the DIC frame turned so that its z is the top "
        f"face's normal; the model's){said}."
    )


def clock_text(imported: dict) -> str:
    """The DIC clock's offset an import chose and the range that fit as well, or '' (none), from
    experiment.json's ``imported`` block (``ExperimentData.imported``)."""
    clock = (imported or {}).get("clock_offset")
    if not clock:
        return ""
    if clock.get("source") == "given":
        return f"DIC clock offset {clock['offset_s']:g} s (given: --time-offset)."
    return (
        f"DIC clock offset {clock['offset_s']:.4g} s found from the data (offsets {clock['low_s']:.4g} .. "
        f"{clock['high_s']:.4g} s fit as well)."
    )


def write_check_report(
    experiment: str | Path, out_dir: str | Path | None = None, mesh: str = "default"
) -> dict:
    """Check an experiment folder and write ``check.json``, the figures and ``index.html`` to
    ``out_dir`` (default ``<experiment>/check``); returns the check's numbers with the paths."""
    exp = load_experiment(experiment, exclude_missing=True)
    out = Path(out_dir) if out_dir is not None else exp.root / "check"
    check = check_experiment(exp, mesh)
    dic = to_model_frame(exp)
    figures = {
        "holds.png": hold_fits_figure(exp, check),
        "coverage.png": dic_coverage_figure(exp, check, dic),
        "sphere.png": sphere_fit_figure(exp, check),
        "registration.png": registration_figure(exp, check, dic),
    }
    for name, fig in figures.items():
        atomic_write(out / name, _png(fig))
    result = check.to_dict()
    clock = clock_text(exp.imported)
    result.update(fiber_text=fiber_text(exp, check), clock_offset=clock or None)
    noise = ", ".join(f"{v:.3g}" for v in check.dic_noise_mm)
    parts = [
        f"<h1>Data check: {html.escape(str(exp.root))}</h1>",
        f"<p>{exp.steps} steps of {exp.step_size:g} mm, sphere R = {exp.radius:g} mm; "
        f"{len(exp.dic_xyz)} DIC points; excluded steps: {check.excluded_steps or 'none'}.</p>",
        "<h2>Warnings</h2>",
        "<ul>" + "".join(f"<li>{html.escape(w)}</li>" for w in check.warnings) + "</ul>"
        if check.warnings
        else "<p>none</p>",
        "<h2>Registration and noise</h2>",
        f"<p>Sphere fit: centre {_fmt(check.sphere_centre_mm)} mm, R = {check.sphere_radius_mm:.4g} mm, residual "
        f"{check.sphere_residual_rms_mm:.3g} mm RMS. Indentation point (DIC frame) "
        f"{_fmt([round(v, 4) for v in check.indentation_point_mm])} mm. {html.escape(fiber_text(exp, check))} "
        f"DIC noise (ux, uy, uz): {noise} mm. Field of view {check.field_of_view_mm:.3g} mm from the axis. "
        f"'{check.mesh}' mesh: {check.nodes_with_data} of {check.nodes} top nodes with DIC data, "
        f"{check.nodes_obscured} obscured.</p>",
        _face(check.registration, check.indentation_signature_mm),
        f"<p>{html.escape(clock)}</p>" if clock else "",
        "<h2>Holds (eq. 9)</h2>",
        _rows(
            result["holds"],
            [
                ("step", "step"),
                ("readings", "readings"),
                ("hold_s", "hold s"),
                ("f_inf_mN", "f_inf mN"),
                ("f_inf_std_mN", "sd mN"),
                ("tau_s", "tau s"),
                ("unrelaxed_pct", "unrelaxed %"),
                ("residual_rms_mN", "residual RMS mN"),
            ],
        ),
        "<h2>DIC coverage</h2>",
        _rows(
            result["coverage"],
            [
                ("step", "step"),
                ("depth_mm", "depth mm"),
                ("points", "points"),
                ("fraction", "fraction"),
                ("shadow_radius_mm", "contact radius mm"),
                ("innermost_point_mm", "innermost point mm"),
                ("outermost_point_mm", "outermost point mm"),
            ],
        ),
        "<h2>Figures</h2>",
    ]
    for name, caption in FIGURES:
        parts.append(
            f'<figure><img src="{name}" alt="{name}" style="max-width:100%"><figcaption>{html.escape(caption)}'
            "</figcaption></figure>"
        )
    page = (
        "<!doctype html><html><head><meta charset='utf-8'><title>Data check</title><style>"
        "body{font-family:system-ui,sans-serif;max-width:1150px;margin:2em auto}table{border-collapse:collapse}"
        "td,th{border:1px solid #ccc;padding:2px 6px}</style></head><body>"
        + "".join(parts)
        + "</body></html>"
    )
    report = atomic_write(out / "index.html", page)
    atomic_write_json(out / "check.json", result)
    result.update(
        report=str(report), check_json=str(out / "check.json"), figures=[str(out / n) for n, _ in FIGURES]
    )
    return result
