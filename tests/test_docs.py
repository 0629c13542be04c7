"""The documentation site builds offline with Sphinx, warnings as errors (docs/conf.py): a broken
link or anchor, an API reference that does not resolve (nitpicky), a docstring that does not parse,
a notebook cell or a gallery example that fails, each fails the build. The notebooks run on small
inputs, the gallery's examples on the coarse mesh.

The build here is the only execution of the notebooks in a test run: it executes them into a fresh
cache of its own (not build/jupyter_cache, which may hold outputs of an older library), and the
notebook tests below read the executed notebooks from that cache and check their figures and the
numbers they print (tests/notebook_checks.py). The site's build and those checks are in this one
file so that they run in one test process (pytest-xdist, --dist loadfile) with the site built once."""

from __future__ import annotations

import importlib
import os
import re
import subprocess
import sys
from pathlib import Path

import nbformat
import pytest
from jupyter_cache import get_cache
from notebook_checks import CHECKS, FIGURES, printed_numbers

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs"))

from api_pages import SUBPACKAGES, lazy_exports  # noqa: E402
from references import EXISTS, escape_docstring, import_path  # noqa: E402

#: Where myst-nb runs each notebook (the folder of the copy the site reads: docs/conf.py).
NOTEBOOK_CWD = ROOT / "docs" / "notebooks"


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The site, built as CI builds it from a clean clone: every notebook executed by this build,
    on small inputs, into the cache ``<site>/../jupyter_cache``."""
    out = tmp_path_factory.mktemp("docs")
    build = [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html"]
    build += ["-D", f"nb_execution_cache_path={out / 'jupyter_cache'}"]
    run = subprocess.run(
        [*build, "-d", str(out / "doctrees"), str(ROOT / "docs"), str(out / "site")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env={**os.environ, "INDENT_STUDIO_SMALL": "1"},
    )
    warnings = [line for line in run.stderr.splitlines() if "WARNING" in line and "IPKernelApp" not in line]
    assert run.returncode == 0 and not warnings, run.stdout[-4000:] + run.stderr[-6000:]
    return out / "site"


def executed_notebook(site: Path, stem: str):
    """notebooks/<stem>.ipynb with the outputs of its execution by the site's build (the cache
    matches it by its code cells: the executed notebook is the stored one)."""
    book = nbformat.read(ROOT / "notebooks" / f"{stem}.ipynb", as_version=4)
    _, executed = get_cache(site.parent / "jupyter_cache").merge_match_into_notebook(book)
    return executed


@pytest.mark.slow
def test_docs_build_strict_with_every_section(site):
    for page in (
        "index",
        "guide/simulate",
        "explanation/friction",
        "validation/verification",
        "architecture",
        "api/index",
        "api/generated/forward",
        "api/generated/forward.spec",
        "notebooks/01_forward_model",
        "auto_examples/index",
        "changelog",
    ):
        assert (site / f"{page}.html").is_file(), page
    api = (site / "api" / "generated" / "forward.spec.html").read_text()
    assert 'id="indentation_studio.forward.ModelSpec"' in api  # the lazily exported names resolved
    assert (site / "searchindex.js").is_file()  # search works from a served site and from a file


@pytest.mark.slow
def test_docs_api_documents_every_public_name_on_its_module_page(site):
    """One page per public module, each name in each subpackage's ``__all__`` documented once."""
    for sub in SUBPACKAGES:
        _, groups = lazy_exports(ROOT / sub / "__init__.py")
        for module, names in groups.items():
            page = (site / "api" / "generated" / f"{sub}.{module}.html").read_text()
            for name in names:
                assert f'id="indentation_studio.{sub}.{name}"' in page, f"{sub}.{module}: {name}"


@pytest.mark.slow
def test_docs_notebooks_and_gallery_are_executed_with_their_figures(site):
    for stem, count in FIGURES.items():
        page = (site / "notebooks" / f"{stem}.html").read_text()
        assert page.count("<img") == count, f"{stem}: {page.count('<img')} figures"
    examples = sorted((ROOT / "gallery").glob("plot_*.py"))
    assert len(examples) == 4
    for example in examples:
        page = (site / "auto_examples" / f"{example.stem}.html").read_text()
        images = re.findall(r'<img [^>]*src="([^"]+sphx_glr_[^"]+\.png)"', page)
        assert images and all((site / "auto_examples" / src).resolve().is_file() for src in images), example


@pytest.mark.slow
@pytest.mark.parametrize("stem", sorted(FIGURES))
def test_notebook_runs_and_shows_its_figures(site, stem):
    """Each notebook ran to the end in the site's build (every code cell executed, an error fails
    the build), showed its figures inline, wrote no PNG where it ran, and printed numbers that agree
    with those tests/notebook_checks.py computes on its own."""
    book = executed_notebook(site, stem)
    code = [c for c in book.cells if c.cell_type == "code" and c.source.strip()]
    assert all(c.execution_count for c in code), f"{stem}: cells not executed by the build"
    images = [o for c in code for o in c.outputs if "image/png" in o.get("data", {})]
    assert len(images) == FIGURES[stem], f"{stem} showed {len(images)} figures inline"
    written = sorted(NOTEBOOK_CWD.rglob("*.png"))
    assert not written, f"figures are shown inline, not written by the notebooks: {written}"
    CHECKS[stem](printed_numbers(book))


@pytest.mark.slow
def test_docs_guide_pages_show_the_figures_of_their_workflow(site):
    """The guide pages of a simulation, a surrogate, Table 1 and a fit show the figure the gallery's
    example drew for that workflow when the site was built."""
    for page, example in {
        "simulate": "plot_01_simulate",
        "surrogates": "plot_02_campaign_and_surrogate",
        "design": "plot_03_table1",
        "fit-and-posterior": "plot_04_fit_and_corner",
    }.items():
        html = (site / "guide" / f"{page}.html").read_text()
        images = re.findall(r'<img [^>]*src="([^"]+\.png)"', html)
        assert any(f"sphx_glr_{example}_" in src for src in images), f"{page}: {images}"
        assert all((site / "guide" / src).resolve().is_file() for src in images), page


@pytest.mark.slow
def test_docs_campaign_and_febio_guides_show_the_figures_their_commands_write(site):
    """The campaign and FEBio guide pages show a figure stored in the docs, with the command that
    wrote it beside it: a script of benchmarks/ or docs/figures/ that exists and names that file."""
    for page, stored in {
        "campaign": "guide/figures/campaign.png",
        "febio": "validation/figures/febio-agreement.png",
    }.items():
        assert (ROOT / "docs" / stored).is_file(), stored
        html = (site / "guide" / f"{page}.html").read_text()
        images = re.findall(r'<img [^>]*src="([^"]+\.png)"', html)
        assert [src for src in images if Path(src).name == Path(stored).name], f"{page}: {images}"
        assert all((site / "guide" / src).resolve().is_file() for src in images), page
        source = (ROOT / "docs" / "guide" / f"{page}.md").read_text()
        scripts = re.findall(r"\.venv/bin/python ((?:benchmarks|docs/figures)/\w+\.py)", source)
        assert scripts and all((ROOT / s).is_file() for s in scripts), page
        assert any(f"docs/{stored}" in (ROOT / s).read_text() for s in scripts), (page, scripts)


@pytest.mark.slow
def test_docs_validation_pages_show_their_figures(site):
    """The validation pages show the figures of their measurements, each PNG stored beside the
    page (docs/validation/figures/) and its caption naming the script in docs/figures/ that made it."""
    for page, figures in {
        "verification": 2,
        "febio-agreement": 1,
        "solver-and-speed": 1,
    }.items():
        html = (site / "validation" / f"{page}.html").read_text()
        images = re.findall(r'<img [^>]*src="([^"]+\.png)"', html)
        assert len(images) >= figures, f"{page}: {images}"
        assert all((site / "validation" / src).resolve().is_file() for src in images), page
        source = (ROOT / "docs" / "validation" / f"{page}.md").read_text()
        scripts = re.findall(r"\.venv/bin/python (docs/figures/\w+\.py)", source)
        assert len(scripts) >= figures and all((ROOT / s).is_file() for s in scripts), page


def test_docs_references_resolve_to_public_names_or_stay_broken():
    """docs/references.py finds the object a docstring's reference names (the public page then
    links it), a field or instance attribute as existing, and nothing for a name that does not
    exist (left unresolved, so that nitpicky fails the build on it)."""
    surrogate = importlib.import_module("indentation_studio.surrogate")
    found = import_path("indentation_studio.surrogate.training.train_surrogate")
    assert found is surrogate.train_surrogate
    assert import_path("indentation_studio.surrogate.training.no_such_name") is None
    assert import_path("indentation_studio.campaign.store.CampaignStore.problems") is EXISTS
    assert import_path("indentation_studio.forward.spec.ModelSpec.no_such_field") is None


def test_docs_docstrings_escape_bars_outside_literals():
    lines = ['the norm |u| of ``a | b``, pattern "*.csv"', "a table | cell"]
    escape_docstring(None, "function", "f", None, {}, lines)
    assert lines == ['the norm \\|u\\| of ``a | b``, pattern "\\*.csv"', "a table | cell"]


def test_docs_home_shows_the_readme_commands():
    readme = (ROOT / "README.md").read_text()
    home = (ROOT / "docs" / "index.md").read_text()
    commands = [line for line in readme.splitlines() if line.startswith("python3 -m venv ")]
    assert len(commands) == 2 and all(command in home.splitlines() for command in commands)
