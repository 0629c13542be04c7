"""Sphinx configuration of the documentation site.

Build (offline, warnings as errors; tests/test_docs.py runs the same)::

    .venv/bin/sphinx-build -W --keep-going -b html docs site

The pages are MyST Markdown (``docs/**/*.md``); the notebooks (``notebooks/``, linked from
``docs/notebooks/``) are executed by myst-nb on small inputs and cached in ``build/jupyter_cache``;
the gallery's scripts (``gallery/``) run at build time into ``docs/auto_examples/``; the API pages
are written from the subpackages' ``__all__`` by ``docs/api_pages.py`` into ``docs/api/generated/``.
"""

from __future__ import annotations

import json
import os
import shutil
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(DOCS))

# The notebooks and the gallery run on the small inputs the test suite uses (coarse mesh, few steps);
# their kernels and the gallery's scripts inherit this environment.
os.environ.setdefault("INDENT_STUDIO_SMALL", "1")

from api_pages import write_api_pages  # noqa: E402
from references import escape_docstring, resolve_internal  # noqa: E402

import indentation_studio  # noqa: E402

write_api_pages(DOCS / "api" / "generated")

# The notebooks stay in notebooks/ (stored without outputs); the site reads copies, executed in their
# folder here (tests/test_docs.py checks what this build's executions printed and showed).
for _notebook in sorted((ROOT / "notebooks").glob("*.ipynb")):
    _copy = DOCS / "notebooks" / _notebook.name
    if not _copy.is_file() or _copy.read_bytes() != _notebook.read_bytes():
        shutil.copyfile(_notebook, _copy)

project = "Indentation Studio"
author = "Indentation Studio developers"
copyright = "the Indentation Studio developers"
release = version = indentation_studio.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "numpydoc",
    "myst_nb",
    "sphinx_gallery.gen_gallery",
]

exclude_patterns = ["_build", "**.ipynb_checkpoints", "auto_examples/*.ipynb", "auto_examples/*.py"]
nitpicky = True
suppress_warnings = []

# MyST: the pages stay Markdown; `page.md#heading` links resolve to the heading's anchor
myst_enable_extensions = ["colon_fence"]
myst_heading_anchors = 4

# The notebooks' kernel: this Python, its log at ERROR, so that ipykernel's notice that the kernel
# talks to the build over local TCP (printed once per notebook) is not the build's output; a cell's
# error still fails the build (it comes as the cell's output, not as a log line).
_kernels = ROOT / "build" / "jupyter_kernels"
(_kernels / "kernels" / "python3").mkdir(parents=True, exist_ok=True)
(_kernels / "kernels" / "python3" / "kernel.json").write_text(
    json.dumps(
        {
            "argv": [
                sys.executable,
                "-m",
                "ipykernel_launcher",
                "-f",
                "{connection_file}",
                "--IPKernelApp.log_level=ERROR",
            ],
            "display_name": "Python 3",
            "language": "python",
        }
    )
)
os.environ["JUPYTER_PATH"] = os.pathsep.join(filter(None, [str(_kernels), os.environ.get("JUPYTER_PATH")]))

# myst-nb: the notebooks run at build time and are cached; an error in a cell fails the build
nb_execution_mode = "cache"
nb_execution_cache_path = str(ROOT / "build" / "jupyter_cache")
nb_execution_timeout = 900
nb_execution_raise_on_error = True
nb_execution_show_tb = True
nb_merge_streams = True

# autodoc + numpydoc: the docstrings are numpy style; signatures without annotations (the types
# are in the Parameters sections)
autodoc_typehints = "none"
autodoc_member_order = "bysource"
autodoc_default_options = {"exclude-members": "__init__, __new__"}
autosummary_generate = False
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

# sphinx-gallery: short examples on the coarse mesh, run at build time, in file-name order
sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "gallery"),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
    "show_memory": False,
    "show_signature": False,
    "image_scrapers": ("matplotlib",),
    "matplotlib_animations": False,
}

html_theme = "pydata_sphinx_theme"
html_title = "Indentation Studio"
html_static_path = ["_static"]
html_css_files = ["custom.css"]
html_show_sourcelink = False
html_copy_source = False
html_theme_options = {
    "navigation_with_keys": False,
    "header_links_before_dropdown": 8,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
}
# the validation pages hold wide figures and tables: their article takes the primary sidebar's width
# (the section is one click away in the header)
html_sidebars = {"index": [], "changelog": [], "validation/*": []}


def setup(app):
    # before numpydoc (priority 500) parses the docstring
    app.connect("autodoc-process-docstring", escape_docstring, priority=400)
    app.connect("missing-reference", resolve_internal)
