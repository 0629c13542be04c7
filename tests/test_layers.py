"""The package layers of docs/architecture.md ("Layers"), read from the source with ast: each
package imports only itself and those below it, at module level and inside functions alike (an
import placed in a function does not dodge a cycle), and no two modules import each other in a
cycle. Imports of the project's own modules inside functions are counted, and the count may only
fall (their place is at the top of the module; lazy_loader makes the packages' names cheap).

Every form of import is read (``from .. import x``, ``from ..x import y``, ``import
indentation_studio.x.y``, ``from indentation_studio import x``); the checker is run on scratch
trees with an upward import of each form written into them, and must fail on each."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import networkx as nx
import pytest

ROOT = Path(__file__).resolve().parents[1]
#: Bottom to top. ``indentation_studio`` is the root package's own modules (atomic writes).
LAYERS = ("indentation_studio", "forward", "campaign", "surrogate", "design", "inference", "studio")
#: Own-module imports inside functions: 119 before the layers were checked, 76 since, 25 once the
#: commands reached the library through the lazy packages, 11 once forward, campaign and inference
#: imported at the top (the 11 left: the commands' and the surrogate kinds' loading of what pulls
#: torch, scikit-learn, matplotlib or pandas, tests/test_cold_start.py), 8 once the surrogate
#: kinds were made through their registry (surrogate.registry.surrogate_class), 4 once `surrogate
#: evaluate` and `convert` read the surrogate package's lazy names; it may only fall.
MAX_IMPORTS_IN_FUNCTIONS = 4


def _modules(root: Path = ROOT) -> dict[str, Path]:
    """'package[.subpackage].module' -> file, for every module of the layers (subpackages too) in
    the tree at ``root`` (the repository, or a scratch tree of the same layout)."""
    out = {}
    for pkg in LAYERS:
        folder = root / pkg
        for f in sorted(folder.rglob("*.py")) if folder.is_dir() else ():
            rel = f.relative_to(folder).with_suffix("").parts
            out[".".join((pkg, *rel))] = f
    return out


def _known(modules: dict[str, Path]) -> set[str]:
    """The names of the modules and of the packages (a package is named without its ``__init__``)."""
    return set(modules) | {m.removesuffix(".__init__") for m in modules}


def _layer_name(module: list[str]) -> list[str]:
    """A module path as :func:`_modules` names it: 'indentation_studio.forward.mesh' is
    'forward.mesh'; the root package and its own modules keep 'indentation_studio'."""
    if module[:1] == ["indentation_studio"] and len(module) > 1 and module[1] in LAYERS:
        return module[1:]
    return module


def _imports(name: str, path: Path, known: set[str]) -> list[tuple[str, bool]]:
    """(imported module as 'package[.sub].module', inside a function?) for every own-module import
    of module ``name`` (a key of :func:`_modules`), in each form: ``import indentation_studio.x.y``,
    ``from indentation_studio import x``, ``from indentation_studio.x import y``, ``from .. import
    x``, ``from ..x import y``. An imported name that is a module (``known``) is that module, any
    other name the module it comes from: ``from .. import inference`` is an import of
    ``inference``, never of the root package."""
    tree = ast.parse(path.read_text())
    in_function = set()
    for fn in ast.walk(tree):
        if isinstance(fn, ast.FunctionDef | ast.AsyncFunctionDef):
            in_function |= {id(n) for n in ast.walk(fn) if isinstance(n, ast.Import | ast.ImportFrom)}
    parts = name.split(".")
    # the package a module sits in, rooted at 'indentation_studio' (the root package's own modules)
    own = (["indentation_studio"] if parts[0] != "indentation_studio" else []) + parts[:-1]
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            modules = [a.name.split(".") for a in node.names]
            targets = [_layer_name(m) for m in modules if m[0] == "indentation_studio"]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = own[: len(own) - (node.level - 1)]
            elif (node.module or "").split(".")[0] == "indentation_studio":
                base = []
            else:
                continue
            module = base + (node.module.split(".") if node.module else [])
            targets = []
            for alias in node.names:
                submodule = _layer_name([*module, alias.name])
                targets.append(submodule if ".".join(submodule) in known else _layer_name(module))
        else:
            continue
        found += [(".".join(t), id(node) in in_function) for t in targets]
    return found


#: A module path written as a string (what ``importlib.import_module`` or a lazy registry takes).
_MODULE_PATH = re.compile(r"indentation_studio\.(\w+)(\.\w+)*")


def _module_strings(path: Path) -> list[str]:
    """Every string constant of a module that is a module path of the package, docstrings left out."""
    tree = ast.parse(path.read_text())
    docstrings = {
        id(node.body[0].value)
        for node in ast.walk(tree)
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef)
        and node.body
        and isinstance(node.body[0], ast.Expr)
        and isinstance(node.body[0].value, ast.Constant)
    }
    return [
        node.value
        for node in ast.walk(tree)
        if isinstance(node, ast.Constant)
        and isinstance(node.value, str)
        and id(node) not in docstrings
        and _MODULE_PATH.fullmatch(node.value)
    ]


def _graph(root: Path = ROOT) -> tuple[dict[str, Path], list[tuple[str, str, bool]]]:
    """The modules of the tree at ``root`` and every own-module import: (importer, imported, inside
    a function?)."""
    modules = _modules(root)
    known = _known(modules)
    edges = []
    for name, path in modules.items():
        for target, inside in _imports(name, path, known):
            edges.append((name, target, inside))
    return modules, edges


def upward_imports(root: Path = ROOT) -> list[str]:
    """'importer -> imported' for every import against the layers in the tree at ``root``."""
    _, edges = _graph(root)
    rank = {pkg: k for k, pkg in enumerate(LAYERS)}
    return sorted(
        f"{src} -> {dst}{' (inside a function)' if inside else ''}"
        for src, dst, inside in edges
        if dst.split(".")[0] in rank and rank[dst.split(".")[0]] > rank[src.split(".")[0]]
    )


def test_each_package_imports_only_the_layers_below_it():
    upward = upward_imports()
    assert not upward, "imports against the layers:\n" + "\n".join(upward)


#: Each form of an upward import (forward importing inference), as a module of ``forward`` writes it.
UPWARD_FORMS = {
    "relative package": "from .. import inference",
    "relative module": "from .. import atomic_write, inference",
    "relative from": "from ..inference import fit",
    "relative from module": "from ..inference.fit import theta",
    "absolute import": "import indentation_studio.inference.fit",
    "absolute import as": "import indentation_studio.inference as inf",
    "absolute from root": "from indentation_studio import inference",
    "absolute from": "from indentation_studio.inference import fit",
    "inside a function": "def load():\n    from .. import inference\n    return inference",
}


def _scratch_tree(root: Path, module: str, source: str) -> None:
    """A tree of the repository's layout at ``root`` (forward, inference with a module ``fit``, the
    root package's atomic_write) and the scratch module ``module`` ('forward.x') holding ``source``."""
    for pkg in ("forward", "forward/febio", "inference", "indentation_studio"):
        (root / pkg).mkdir(parents=True, exist_ok=True)
        (root / pkg / "__init__.py").write_text("")
    (root / "inference" / "fit.py").write_text("theta = 1.0\n")
    (root / "indentation_studio" / "atomic_write.py").write_text("")
    (root / Path(*module.split("."))).with_suffix(".py").write_text(source + "\n")


@pytest.mark.parametrize("form", sorted(UPWARD_FORMS))
def test_the_check_fails_on_an_upward_import_in_any_form(tmp_path, form):
    _scratch_tree(tmp_path, "forward.scratch", UPWARD_FORMS[form])
    found = upward_imports(tmp_path)
    assert found and all(f.startswith("forward.scratch -> inference") for f in found), found


def test_the_check_fails_on_an_upward_import_from_a_subpackage(tmp_path):
    _scratch_tree(tmp_path, "forward.febio.scratch", "from ... import inference")
    assert upward_imports(tmp_path) == ["forward.febio.scratch -> inference"]


def test_the_check_passes_imports_down_the_layers(tmp_path):
    down = "from .. import atomic_write, forward\nfrom ..forward import febio\nimport indentation_studio"
    _scratch_tree(tmp_path, "inference.scratch", down)
    assert upward_imports(tmp_path) == []


def test_no_module_forwards_to_a_layer_above_it_by_strings():
    """A module path in a string (``importlib.import_module("indentation_studio.inference.x")``,
    a ``__getattr__`` that fetches names from there) is an import the check above cannot see:
    none may name a module of a layer above the module's own."""
    rank = {pkg: k for k, pkg in enumerate(LAYERS)}
    upward = sorted(
        f"{name} names {text!r}"
        for name, path in _modules().items()
        for text in _module_strings(path)
        if rank.get(text.split(".")[1], -1) > rank[name.split(".")[0]]
    )
    assert not upward, "module paths against the layers, written as strings:\n" + "\n".join(upward)


def test_no_module_cycle_even_through_imports_inside_functions():
    modules, edges = _graph()
    graph = nx.DiGraph()
    known = set(modules) | {m.removesuffix(".__init__") for m in modules}
    graph.add_edges_from(
        (s.removesuffix(".__init__"), d)
        for s, d, _ in edges
        if d in known and s.removesuffix(".__init__") != d
    )
    cycles = sorted(" -> ".join(c) for c in nx.simple_cycles(graph))
    assert not cycles, "module cycles:\n" + "\n".join(cycles[:20])


def test_imports_inside_functions_only_fall():
    _, edges = _graph()
    inside = [(s, d) for s, d, i in edges if i]
    assert len(inside) <= MAX_IMPORTS_IN_FUNCTIONS, (
        f"{len(inside)} imports of the project's own modules inside functions (at most "
        f"{MAX_IMPORTS_IN_FUNCTIONS}); put new ones at the top of the module"
    )


def test_the_layer_order_is_the_architecture_pages():
    page = (ROOT / "docs" / "architecture.md").read_text()
    stated = " < ".join(f"`{p}`" for p in LAYERS[1:])
    assert stated in page, f"docs/architecture.md must state the layers as {stated}"
