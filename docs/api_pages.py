"""The API reference's pages, written by ``docs/conf.py`` before each build into ``docs/api/generated/``.

Each subpackage declares its public names with ``lazy_loader.attach(submod_attrs={...})``: the
names and the module each comes from. From that declaration this writes one page per subpackage
(its docstring and an autosummary table of its names, grouped by the module that defines them) and
one page per public module (the names that module gives its subpackage, documented by autodoc and
numpydoc under the subpackage's path, e.g. ``indentation_studio.forward.ModelSpec``). A module
listed in ``submodules=`` (``forward.febio``, ``studio.figures``, ``inference.lab``) gets a page of
its own public names.
"""

from __future__ import annotations

import ast
import importlib
import inspect
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = "indentation_studio"
SUBPACKAGES = ["forward", "campaign", "surrogate", "design", "inference", "studio"]


def lazy_exports(init: Path) -> tuple[list[str], dict[str, list[str]]]:
    """The literal ``submodules`` and ``submod_attrs`` of the ``lazy.attach`` call in ``init``."""
    for node in ast.parse(init.read_text()).body:
        if isinstance(node, ast.Assign) and isinstance(node.value, ast.Call):
            if getattr(node.value.func, "attr", "") == "attach":
                keywords = {kw.arg: ast.literal_eval(kw.value) for kw in node.value.keywords}
                return keywords.get("submodules", []) or [], keywords.get("submod_attrs", {}) or {}
    return [], {}


def _title(text: str, mark: str = "=") -> str:
    return f"{text}\n{mark * len(text)}\n"


def _directive(package: str, name: str, no_index: bool = False) -> str:
    obj = getattr(importlib.import_module(package), name)
    option = "   :no-index:\n" if no_index else ""
    if inspect.isclass(obj):
        return f".. autoclass:: {name}\n   :members:\n{option}"
    if inspect.isroutine(obj):
        return f".. autofunction:: {name}\n{option}"
    return f".. autodata:: {name}\n   :no-value:\n{option}"


def _module_page(package: str, module: str, names: list[str]) -> str:
    parts = [
        _title(f"{package.removeprefix(PACKAGE + '.')}.{module}"),
        f"The public names that ``{package}`` takes from its module ``{module}``.\n",
        f".. currentmodule:: {package}\n",
    ]
    parts += [_directive(package, name) for name in names]
    return "\n".join(parts)


def _submodule_page(package: str, module: str, exported: set[int]) -> str:
    """A public module's page; the names its package also exports are documented there, and shown
    here without a second index entry."""
    full = f"{package}.{module}"
    imported = importlib.import_module(full)
    names = list(getattr(imported, "__all__", []))
    parts = [_title(f"{package.removeprefix(PACKAGE + '.')}.{module}"), f".. automodule:: {full}\n"]
    if names:
        parts.append(f".. currentmodule:: {full}\n")
        parts += [_directive(full, name, id(getattr(imported, name)) in exported) for name in names]
    return "\n".join(parts)


def _package_page(package: str, groups: dict[str, list[str]], submodules: list[str], stem: str) -> str:
    parts = [
        _title(f"``{package}``"),
        f".. automodule:: {package}\n   :no-members:\n",
        f".. currentmodule:: {package}\n",
    ]
    for module, names in groups.items():
        parts.append(_title(f"{module}", "-"))
        parts.append(f"Documented on :doc:`{stem}.{module}`.\n")
        parts.append(".. autosummary::\n\n" + "".join(f"   {name}\n" for name in names))
    modules = [m for m in submodules if m not in groups]
    if modules:
        parts.append(_title("Modules", "-"))
        parts.append("".join(f"* :doc:`{stem}.{m}`: ``{package}.{m}``\n" for m in modules))
    pages = [f"{stem}.{m}" for m in dict.fromkeys([*groups, *submodules])]
    parts.append(".. toctree::\n   :hidden:\n\n" + "".join(f"   {p}\n" for p in pages))
    return "\n".join(parts)


def _top_page() -> str:
    """The names ``import indentation_studio as ins`` reaches directly, each linked to its page."""
    _, groups = lazy_exports(ROOT / PACKAGE / "__init__.py")
    parts = [
        _title(f"``{PACKAGE}``"),
        f".. automodule:: {PACKAGE}\n   :no-members:\n",
        f".. currentmodule:: {PACKAGE}\n",
    ]
    for sub, names in groups.items():
        parts.append(f"From :doc:`{sub}`:\n")
        parts.append(".. autosummary::\n\n" + "".join(f"   ~{sub}.{name}\n" for name in names))
    return "\n".join(parts)


def _write(path: Path, text: str) -> None:
    """Write only when the text changed, so that Sphinx rebuilds only the pages that did."""
    if not path.is_file() or path.read_text() != text:
        path.write_text(text)


def write_api_pages(out: Path) -> list[Path]:
    """Write the subpackage and module pages under ``out``; return the pages written."""
    out.mkdir(parents=True, exist_ok=True)
    wanted: dict[Path, str] = {out / "top.rst": _top_page()}
    for sub in SUBPACKAGES:
        package = f"{PACKAGE}.{sub}"
        submodules, groups = lazy_exports(ROOT / sub / "__init__.py")
        wanted[out / f"{sub}.rst"] = _package_page(package, groups, submodules, sub)
        for module, names in groups.items():
            wanted[out / f"{sub}.{module}.rst"] = _module_page(package, module, names)
        imported = importlib.import_module(package)
        exported = {id(getattr(imported, name)) for names in groups.values() for name in names}
        for module in submodules:
            if module not in groups:  # else that module's page lists the names it exports
                wanted[out / f"{sub}.{module}.rst"] = _submodule_page(package, module, exported)
    for stale in set(out.glob("*.rst")) - set(wanted):
        stale.unlink()
    for path, text in wanted.items():
        _write(path, text)
    return sorted(wanted)
