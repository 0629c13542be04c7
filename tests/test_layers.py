"""The package layers of docs/architecture.md ("Layers"), read from the source with ast: each
package imports only itself and those below it, at module level and inside functions alike (an
import placed in a function does not dodge a cycle), and no two modules import each other in a
cycle. Imports of the project's own modules inside functions are counted, and the count may only
fall (their place is at the top of the module; lazy_loader makes the packages' names cheap)."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import networkx as nx

ROOT = Path(__file__).resolve().parents[1]
#: Bottom to top. ``indentation_studio`` is the root package's own modules (atomic writes).
LAYERS = ("indentation_studio", "forward", "campaign", "surrogate", "design", "inference", "studio")
#: Own-module imports inside functions: 119 before the layers were checked, 76 since, 25 once the
#: commands reached the library through the lazy packages, 11 once forward, campaign and inference
#: imported at the top (the 11 left: the commands' and the surrogate kinds' loading of what pulls
#: torch, scikit-learn, matplotlib or pandas, tests/test_cold_start.py), 8 once the surrogate
#: kinds were made through their registry (surrogate.registry.surrogate_class); it may only fall.
MAX_IMPORTS_IN_FUNCTIONS = 8


def _modules() -> dict[str, Path]:
    """'package[.subpackage].module' -> file, for every module of the layers (subpackages too)."""
    out = {}
    for pkg in LAYERS:
        folder = ROOT / pkg
        for f in sorted(folder.rglob("*.py")):
            rel = f.relative_to(folder).with_suffix("").parts
            out[".".join((pkg, *rel))] = f
    return out


def _imports(name: str, path: Path) -> list[tuple[str, bool]]:
    """(imported module as 'package[.sub].module', inside a function?) for every own-module import
    of module ``name`` (a key of :func:`_modules`)."""
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
        if not isinstance(node, ast.ImportFrom):
            continue
        if node.level:
            base = own[: len(own) - (node.level - 1)]
        elif (node.module or "").startswith("indentation_studio"):
            base = []
        else:
            continue
        module = base + (node.module.split(".") if node.module else [])
        if module[:1] == ["indentation_studio"] and len(module) > 1 and module[1] in LAYERS:
            module = module[1:]
        if not node.module:  # "from . import x" / "from .. import forward": the names are modules
            targets = [".".join([*module, a.name]) for a in node.names]
        else:
            targets = [".".join(module)]
        found += [(t, id(node) in in_function) for t in targets]
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


def _graph():
    modules = _modules()
    edges = []
    for name, path in modules.items():
        for target, inside in _imports(name, path):
            edges.append((name, target, inside))
    return modules, edges


def test_each_package_imports_only_the_layers_below_it():
    _, edges = _graph()
    rank = {pkg: k for k, pkg in enumerate(LAYERS)}
    upward = sorted(
        f"{src} -> {dst}{' (inside a function)' if inside else ''}"
        for src, dst, inside in edges
        if dst.split(".")[0] in rank and rank[dst.split(".")[0]] > rank[src.split(".")[0]]
    )
    assert not upward, "imports against the layers:\n" + "\n".join(upward)


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
