"""The five notebooks in notebooks/ are stored without outputs and import only the public API
(names in a package's ``__all__``).

That they run to the end on small inputs, show their figures inline, write no PNG and print
numbers that agree with values the test computes on its own is checked on the executions of the
documentation build (``tests/test_docs.py``, the checks in ``tests/notebook_checks.py``): the
notebooks run once per test run, not once here and again in the build."""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import nbformat
import pytest

NOTEBOOKS = sorted((Path(__file__).resolve().parents[1] / "notebooks").glob("*.ipynb"))


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
