"""The demo's report: one self-contained HTML page (tables and the PNGs beside it)."""

from __future__ import annotations

import html
import math
import os
from pathlib import Path

import pandas as pd

from .. import __version__
from ..atomic_write import atomic_write
from .mu_wording import mu_statement

STYLE = """
body { font-family: system-ui, sans-serif; max-width: 1100px; margin: 2em auto; color: #222; }
.table { overflow-x: auto; max-width: 100%; margin: 1em 0; }
table { border-collapse: collapse; font-size: 0.9em; } td, th { border: 1px solid #ccc; padding: 3px 6px; }
td { white-space: nowrap; } th { white-space: normal; max-width: 9em; vertical-align: bottom; }
.docs { font-size: 0.9em; color: #555; }
th { background: #f2f2f2; } img { max-width: 100%; border: 1px solid #ddd; } figcaption { color: #555; }
.alarm { border: 3px solid #c00; background: #fee; padding: 0.6em 1em; margin: 1em 0; }
.caution { border: 3px solid #c80; background: #ffd; padding: 0.6em 1em; margin: 1em 0; }
"""


def _table(rows: list[dict], columns: dict[str, str]) -> str:
    head = "".join(f"<th>{html.escape(label)}</th>" for label in columns.values())
    body = "".join(
        "<tr>"
        + "".join(
            f"<td>{html.escape(_fmt(r[key], MISSING.get(key, 'not computed')))}</td>" for key in columns
        )
        + "</tr>"
        for r in rows
    )
    return f"<div class='table'><table><tr>{head}</tr>{body}</table></div>"


#: What a missing value means, by column (otherwise "not computed").
MISSING = {"fov_mm": "whole top"}

#: The docs page (under docs/) that explains each section of the report.
SECTION_DOCS = {
    "Table 1": "guide/design.md",
    "Surrogates": "guide/surrogates.md",
    "Which experiment to run": "guide/design.md",
    "The example experiment": "guide/fit-and-posterior.md",
    "Figures": "validation/index.md",
}


def _fmt(v, missing: str = "not computed") -> str:
    if isinstance(v, float):
        return missing if math.isnan(v) else f"{v:.3g}"
    if isinstance(v, (list, tuple)):
        return "(" + ", ".join(_fmt(x) for x in v) + ")"
    return str(v)


def correction_sentence(fit: dict) -> str:
    """Where an error budget corrected the fit (its model's fit moved to the converged model's, issue
    57's rule), the model's own fit and the correction, as the fit command prints them; else "".

    Parameters
    ----------
    fit : dict
        The demo's fit record: ``model_fit`` and, where corrected, ``correction`` (fit.json's).

    Returns
    -------
    str
        One sentence of HTML, with a trailing space, or "".
    """
    correction = fit.get("correction")
    if correction is None:
        return ""
    model_fit = fit["model_fit"]
    return (
        f"Corrected from the model's fit c1 = {model_fit[0]:.3f}, c5 = {model_fit[1]:.1f} kPa by "
        f"{correction['c1_pct']:+.2f} % / {correction['c5_pct']:+.2f} % (the error budget's correction "
        "to the converged model). "
    )


def bounds_sentence(fit: dict) -> str:
    """What a fit's bounds hold, in one sentence of HTML; a fit the adequacy test flags says what
    they do not hold instead (the model's own misfit), never "these bounds hold"."""
    holds = html.escape(fit.get("bounds_include", "the statistical part only"))
    if (fit.get("adequacy") or {}).get("flagged"):
        return (
            "<b>These bounds do not hold the truth's distance from this fit:</b> the model cannot explain "
            f"these data (adequacy flagged, above), and the bounds were made for {holds}, not for the "
            "misfit the adequacy test found."
        )
    return f"These bounds hold: {holds}."


def fit_mu_sentence(fit: dict) -> str:
    """What the fit says of mu, in one sentence of HTML (empty without mu): the fit command's words
    (:func:`studio.mu_wording.mu_statement`), and why mu is not claimed where its model error is
    not measured (fit.json's ``friction``)."""
    fr = fit.get("friction")
    said = mu_statement(fr)
    if not said:
        return ""
    why = fr.get("mu_model_unmeasured")
    reason = f" mu not claimed: {why}." if why else ""
    return html.escape(f"The fit: {said}.{reason}")


def posterior_html(post: dict) -> str:
    """The posterior's paragraph: its intervals beside the fit's bounds, mu's identification, the chain.

    One thing per number: the fit's bounds are eq. 6 at the fit (a Gaussian in log theta) with the
    model-error parts added in quadrature; the posterior samples the likelihood and is spread by the
    same parts, so the two agree where the objective is near quadratic over the bounds, and where
    they differ the posterior's shape (skew, a prior's end) is the reason, said here.
    """
    names = ["c1", "c5", "mu"][: len(post["median"])]
    cells = []
    for k, name in enumerate(names):
        lo, hi = post["ci95"][k]
        if name in post.get("not_identified", []):
            cells.append(
                f"{name} not identified: its 95 % interval [{lo:.3g}, {hi:.3g}] reaches its prior's end"
            )
            continue
        text = f"{name} median {post['median'][k]:.4g}, 95 % [{lo:.4g}, {hi:.4g}]"
        bounds = post.get("fit_bounds")
        if bounds is not None and k < len(bounds):
            width, fit_width = hi - lo, bounds[k][1] - bounds[k][0]
            text += f" (the fit's bounds [{bounds[k][0]:.4g}, {bounds[k][1]:.4g}], width ratio {width / fit_width:.2f})"
        cells.append(text)
    converged = post.get("convergence") or f"converged {post.get('converged')}"
    return (
        "<p>Posterior (emcee on the surrogate, spread by the same model-error parts as the fit's bounds): "
        + "; ".join(html.escape(c) for c in cells)
        + f". Chain: {html.escape(converged)}, acceptance {post['acceptance_fraction']:.2f}. The fit's bounds "
        "are eq. 6 at the fit with the model error added in quadrature; the posterior's intervals are the "
        "sampled likelihood spread by the same parts: they agree where the objective is near quadratic over "
        "the bounds, and a width ratio far from 1 is the posterior's shape (skew, an end of the prior).</p>"
    )


def fit_warnings_html(fit: dict) -> str:
    """The warnings a fit's numbers must be read with, as boxes above them: the model-adequacy
    flag (red: the model cannot explain the data) and a test without an error budget (amber);
    a fit not flagged gets its chi-square in one line. ``fit`` holds fit.json's 'adequacy' and
    'error_budget' (absent: nothing said)."""
    parts = []
    adequacy = fit.get("adequacy") or {}
    held = ""
    if adequacy.get("field_error"):
        fe = adequacy["field_error"]
        held = (
            f" The test's covariance held {html.escape(fe['coarse_mesh'])}'s field error against "
            f"{html.escape(fe['fine_mesh'])} (measured at {fe['points']} points, {html.escape(fe['file'])})."
        )
    if adequacy.get("flagged"):
        named = "".join(
            f"<li>{html.escape(d['parameter'])}: {html.escape(d['reason'])}</li>"
            for d in adequacy.get("named_parameters", [])
        )
        parts.append(
            "<div class='alarm'><b>Model inadequate: the model cannot explain these data; its bounds are not "
            f"meaningful.</b> Chi-square {adequacy['statistic']:.4g} on {adequacy['dof']} degrees of freedom "
            f"({adequacy['per_degree']:.3g} per degree), p = {adequacy['p_value']:.3g} &lt; {adequacy['alpha']:g}."
            + held
            + (f"<ul>{named}</ul>" if named else "")
            + "</div>"
        )
    elif "flagged" in adequacy:
        parts.append(
            f"<p>Model adequacy: chi-square {adequacy['statistic']:.4g} on {adequacy['dof']} degrees of "
            f"freedom, p = {adequacy['p_value']:.3g} (not flagged).{held}</p>"
        )
    elif adequacy.get("note"):
        parts.append(f"<p>Model adequacy: not tested ({html.escape(adequacy['note'])}).</p>")
    budget = fit.get("error_budget") or {}
    if budget.get("warning"):
        parts.append(
            f"<div class='caution'><b>{'Error budget not measured here' if budget.get('known') else 'No error budget for this test'}."
            f"</b> {html.escape(budget['warning'])}</div>"
        )
    return "".join(parts)


def _docs_link(out: Path, title: str) -> str:
    """A link from the report to the page of the built documentation site (``site/``, built by
    ``sphinx-build -W --keep-going -b html docs site``) that explains ``title``, in a source
    checkout; when the site is not built yet, the line says how to build it."""
    page = SECTION_DOCS.get(title)
    root = Path(__file__).resolve().parents[1]
    if page is None or not (root / "docs" / page).is_file():
        return ""
    built = root / "site" / page.replace(".md", ".html")
    href = Path(os.path.relpath(built, out.resolve())).as_posix()
    name = page.removesuffix(".md")
    note = (
        ""
        if built.is_file()
        else " (the documentation site is not built yet: <code>.venv/bin/sphinx-build -W --keep-going"
        " -b html docs site</code>)"
    )
    return (
        f"<p class='docs'>What this section means: <a href='{html.escape(href)}'>{html.escape(name)}</a>"
        f"{note}</p>"
    )


def _h2(out: Path, title: str, rest: str = "") -> str:
    return f"<h2>{html.escape(title)}{html.escape(rest)}</h2>" + _docs_link(out, title)


#: The columns of the design comparison (design.experiment_choice.compare_designs), as read.
DESIGN_COLUMNS = {
    "radius_mm": "R (mm)",
    "max_depth_mm": "depth (mm)",
    "steps": "steps",
    "every": "every nth step",
    "fov_mm": "field of view (mm)",
    "s": "s",
    "c1_pct": "c1 % (paper weights)",
    "c5_pct": "c5 % (paper weights)",
    "c1_pct_optimised": "c1 % (optimised)",
    "c5_pct_optimised": "c5 % (optimised)",
    "optimised_weights": "optimised weights (force, ux, uy, uz)",
}


def write_report(out: Path, results: dict, sections: list[tuple[str, str]]) -> Path:
    """Write ``out/index.html`` from the demo's ``results`` and its figures: tables that fit the
    page (they scroll inside it when wider), missing values in words, and each section linked to
    the docs page that explains it."""
    parts = [
        f"<h1>Indentation Studio demo</h1><p>version {__version__}; wall time {results['wall_s']:.0f} s</p>"
    ]
    parts.append(
        _h2(out, "Table 1", " at theta* = {10, 350} kPa, s = 0.05 (exact Hessian, eq. 4 as printed)")
    )
    parts.append(
        _table(
            results["table1"],
            {
                "name": "test design",
                "paper_c1_pct": "paper c1 %",
                "paper_c5_pct": "paper c5 %",
                "paper_weights": "paper weights",
                "c1_pct_at_paper_weights": "ours c1 % (paper weights)",
                "c5_pct_at_paper_weights": "ours c5 % (paper weights)",
                "weights": "our optimal weights",
                "c1_pct": "ours c1 % (optimal)",
                "c5_pct": "ours c5 % (optimal)",
            },
        )
    )
    H, P = results["hessian_at_paper_weights"], results["paper_hessian"]
    parts.append(
        f"<p>H(theta*) at the paper's combined weights: {_fmt(H)}; the paper's eq. 14: {_fmt(P)}.</p>"
    )
    parts.append(_h2(out, "Surrogates", ": errors at held-out points (percent)"))
    rows = [{"kind": k, **v} for k, v in results["surrogate_test_errors"].items()]
    parts.append(
        _table(
            rows,
            {
                "kind": "surrogate",
                "points": "points",
                "force_rms_pct": "force RMS",
                "force_max_pct": "force max",
                "displacement_rms_pct": "field RMS (of max |u|)",
                "displacement_max_pct": "field max",
            },
        )
    )
    csv = out / "design-comparison.csv"
    if csv.is_file():
        parts.append(_h2(out, "Which experiment to run"))
        table = pd.read_csv(csv)
        columns = {k: v for k, v in DESIGN_COLUMNS.items() if k in table.columns}
        parts.append(_table(table.to_dict("records"), columns))
    fit, post = results["fit"], results["posterior"]
    parts.append(_h2(out, "The example experiment"))
    parts.append(fit_warnings_html(fit))
    parts.append(
        f"<p>Fit (on the surrogate, then its FE stage: {fit.get('fe_stage', 'a confirming FE run')}): c1 = {fit['theta'][0]:.3f} kPa +- "
        f"{fit['bounds_pct'][0]:.2f} %, c5 = {fit['theta'][1]:.1f} kPa +- {fit['bounds_pct'][1]:.2f} % (95 %; "
        f"statistical part eq. 6 with s = {fit['s']:.3g} from eq. 8: +- {_fmt(fit.get('statistical_pct', fit['bounds_pct']))} %). "
        f"{correction_sentence(fit)}{bounds_sentence(fit)} {fit_mu_sentence(fit)} "
        f"F = {fit['F']:.3g}. Synthetic truth: {_fmt(fit['truth'])}.</p>"
        + posterior_html(post)
        + f"<p>FE confirmation: F(theta_hat) = {results['confirmation']['F_fe']:.3g}.</p>"
    )
    parts.append(_h2(out, "Figures"))
    for name, caption in sections:
        if name.endswith(".png"):
            parts.append(
                f'<figure><img src="{html.escape(name)}" alt="{html.escape(name)}"><figcaption>{html.escape(caption)}'
                "</figcaption></figure>"
            )
        else:
            parts.append(f"<p><b>{html.escape(name)}</b>: {html.escape(caption)}</p>")
    page = f"<!doctype html><html><head><meta charset='utf-8'><title>Indentation Studio demo</title><style>{STYLE}</style></head><body>{''.join(parts)}</body></html>"
    return atomic_write(out / "index.html", page)
