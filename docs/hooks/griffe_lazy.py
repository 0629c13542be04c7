"""A griffe extension: the public names a package exports through ``lazy_loader.attach``.

Each subpackage of the studio declares its public names as
``__getattr__, __dir__, __all__ = lazy.attach(__name__, submodules=[...], submod_attrs={...})``.
griffe reads source without running it, so it sees no ``__all__`` there; this extension reads the
call's literal arguments and adds each name as an alias of the object in its submodule, with
``__all__`` set to them, so that ``::: indentation_studio.forward`` documents exactly the
package's public names.
"""

from __future__ import annotations

import ast

import griffe


def _lazy_attach_call(tree: ast.Module) -> ast.Call | None:
    for node in tree.body:
        if isinstance(node, ast.Assign) and isinstance(node.value, ast.Call):
            func = node.value.func
            if isinstance(func, ast.Attribute) and func.attr == "attach":
                return node.value
    return None


class LazyLoaderExports(griffe.Extension):
    """Turn ``lazy.attach(...)`` in a package's ``__init__`` into aliases and ``__all__``."""

    def on_package(self, *, pkg: griffe.Module, **kwargs) -> None:  # griffe >= 1.x
        for module in [pkg, *self._submodules(pkg)]:
            self._apply(module)

    def _submodules(self, module: griffe.Module):
        for member in module.members.values():
            if not member.is_alias and member.is_module:
                yield member
                yield from self._submodules(member)

    def _apply(self, module: griffe.Module) -> None:
        if not module.is_init_module or not module.source:
            return
        call = _lazy_attach_call(ast.parse(module.source))
        if call is None:
            return
        keywords = {kw.arg: kw.value for kw in call.keywords}
        submodules = ast.literal_eval(keywords["submodules"]) if "submodules" in keywords else []
        submod_attrs = ast.literal_eval(keywords["submod_attrs"]) if "submod_attrs" in keywords else {}
        exports: list[str] = []
        for sub, names in submod_attrs.items():
            for name in names:
                if name not in module.members or module.members[name].is_alias:
                    module.set_member(name, griffe.Alias(name, f"{module.path}.{sub}.{name}", parent=module))
                exports.append(name)
        exports.extend(name for name in submodules if name not in exports)
        module.exports = exports
