"""Every notebook in notebooks/ runs to the end on small inputs (INDENT_STUDIO_SMALL=1) with nbclient,
shows its figures inline, and imports only the public API (names in a package's ``__all__``)."""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

NOTEBOOKS = sorted((Path(__file__).resolve().parents[1] / "notebooks").glob("*.ipynb"))
#: The figures each notebook shows (those it wrote as PNG files before the figures were returned).
FIGURES = {
    "01_forward_model": 2,  # force-depth, displacement maps
    "02_campaign_and_surrogates": 1,  # parity
    "03_experiment_design": 2,  # design comparison, Fig. 8
    "04_fitting_an_experiment": 1,  # corner
    "05_composite_phantom": 2,  # Fig. 14, Fig. 12/13
}


def _code(book) -> list[str]:
    return ["".join(c.source) for c in book.cells if c.cell_type == "code"]


def test_there_are_five_notebooks_stored_without_outputs():
    assert [p.name[:2] for p in NOTEBOOKS] == ["01", "02", "03", "04", "05"]
    for path in NOTEBOOKS:
        book = nbformat.read(path, as_version=4)
        assert all(not c.get("outputs") for c in book.cells if c.cell_type == "code"), path.name


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_imports_only_public_names(path):
    for source in _code(nbformat.read(path, as_version=4)):
        for node in ast.walk(ast.parse(source)):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("indentation_studio"):
                package = importlib.import_module(node.module)
                assert node.module.count(".") <= 1, f"{path.name}: deep import from {node.module}"
                for alias in node.names:
                    assert alias.name in package.__all__, (
                        f"{path.name}: {node.module}.{alias.name} is not public"
                    )
            if isinstance(node, ast.Import):
                for alias in node.names:
                    assert not alias.name.startswith("indentation_studio.") or alias.name.count(".") <= 1


@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_runs_and_shows_its_figures(path, tmp_path, monkeypatch):
    monkeypatch.setenv("INDENT_STUDIO_SMALL", "1")
    book = nbformat.read(path, as_version=4)
    NotebookClient(
        book, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}
    ).execute()
    images = [
        o for c in book.cells if c.cell_type == "code" for o in c.outputs if "image/png" in o.get("data", {})
    ]
    assert len(images) == FIGURES[path.stem], f"{path.name} showed {len(images)} figures inline"
    assert not list(tmp_path.glob("*.png")), "figures are shown inline, not written by the notebooks"
