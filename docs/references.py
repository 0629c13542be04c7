"""Sphinx event handlers of the documentation build (``docs/conf.py`` connects them).

``escape_docstring``: the docstrings write absolute values and norms as ``|u|`` (a substitution in
reStructuredText) and the odd ``"*.csv"`` default; both are escaped, outside inline literals, before
numpydoc parses them.

``resolve_internal``: docstrings cite names where they are defined
(``:func:`surrogate.training.train_surrogate```, ``:mod:`forward.mesh```, or relative to their own
module); the API reference documents them where the public imports them
(``indentation_studio.surrogate.train_surrogate``) and has a page per module that defines public
names (``api/generated/forward.mesh``). Such a reference links there; one to a name that exists but
is internal (not exported) is shown as code without a link; one to a name that does not exist stays
unresolved and, the build being nitpicky, fails it.
"""

from __future__ import annotations

import importlib
import inspect
import re
import sys

from sphinx.util.nodes import make_refnode

_LITERAL = re.compile(r"(``.*?``)")
_BARS = re.compile(r"(?<![\\|])\|(?=[^\s|])([^|`]*?[^\s|\\])\|(?![|_])")


def escape_docstring(app, what, name, obj, options, lines):
    for i, line in enumerate(lines):
        if "|" not in line and '"*' not in line:
            continue
        parts = _LITERAL.split(line)
        for j in range(0, len(parts), 2):  # the even parts are outside ``...``
            parts[j] = _BARS.sub(r"\\|\1\\|", parts[j]).replace('"*', '"\\*')
        lines[i] = "".join(parts)


#: What ``import_path`` returns for a dataclass field or an instance attribute: it exists, but
#: there is nothing to import.
EXISTS = object()


def import_path(path: str):
    parts = path.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for attr in parts[cut:]:
            fields = getattr(obj, "__dataclass_fields__", None) or getattr(obj, "__annotations__", {})
            if not hasattr(obj, attr) and inspect.isclass(obj):
                own = [c for c in obj.__mro__ if c.__module__.startswith("indentation_studio.")]
                # an instance attribute may be set by a base class (CampaignStore's problems)
                assigned = any(re.search(rf"self\.{attr}\s*[:=]", inspect.getsource(c)) for c in own)
                if attr in fields or assigned:
                    return EXISTS  # a field or an instance attribute: exists, nothing to import
            if inspect.isclass(obj) and attr in fields and getattr(obj, attr, None) is None:
                return EXISTS  # a field whose default is None (not "no such name")
            try:
                obj = getattr(obj, attr)
            except AttributeError:
                return None
        return obj
    return None


def _documented_objects(env) -> dict[int, str]:
    cache = getattr(env, "_public_by_id", None)
    if cache is None:
        cache = {}
        for name in sorted(env.domains["py"].objects, key=len, reverse=True):
            obj = import_path(name)
            if obj is not None and not isinstance(obj, int | float | str | tuple | dict | list):
                cache[id(obj)] = name
        env._public_by_id = cache
    return cache


def _contexts(node) -> list[str]:
    """Where a relative target may live: the object whose docstring cites it (autodoc records
    "docstring of <its full name>" as the source) and each level above it, then the page's class,
    module and each package above them."""
    contexts = []
    _, _, documented = (node.source or "").partition("docstring of ")
    parts = documented.split(".") if documented else []
    contexts += [".".join(parts[:cut]) for cut in range(len(parts), 0, -1)]
    module = node.get("py:module") or ""
    if node.get("py:class") and module:
        contexts.append(f"{module}.{node['py:class']}")
    parts = module.split(".") if module else []
    contexts += [".".join(parts[:cut]) for cut in range(len(parts), 0, -1)]
    # last, any module of the package the build imported (a class cited from a module that does
    # not import it)
    loaded = sorted(name for name in sys.modules if name.startswith("indentation_studio."))
    return [*dict.fromkeys(contexts), "indentation_studio", "", *loaded]


def resolve_internal(app, env, node, contnode):
    if node.get("refdomain") != "py":
        return None
    target = node["reftarget"].lstrip("~.")
    domain = env.domains["py"]
    for context in _contexts(node):
        full = f"{context}.{target}" if context else target
        if not full.startswith("indentation_studio."):
            continue
        obj = import_path(full)
        if obj is None:
            continue
        if obj is EXISTS:
            return contnode
        if inspect.ismodule(obj):
            docname = "api/generated/" + obj.__name__.removeprefix("indentation_studio.")
            if docname in env.found_docs:
                return make_refnode(app.builder, node["refdoc"], docname, "", contnode, obj.__name__)
            return contnode
        name = _documented_objects(env).get(id(obj))
        if name is None:
            return contnode  # internal: exists, not in the API reference
        entry = domain.objects[name]
        return make_refnode(app.builder, node["refdoc"], entry.docname, entry.node_id, contnode, name)
    return None
