"""MkDocs hook: lay out the package as Python imports it, for griffe to read.

``pyproject.toml`` maps the top-level folders (``forward/``, ``design/``, ...) into the one import
name ``indentation_studio`` (``[tool.setuptools.package-dir]``). griffe reads source files without
importing them, so it looks for ``indentation_studio/forward/`` and finds nothing. Before the build,
this hook lays ``build/griffe/indentation_studio/`` out as the installed package looks: copies of the
package's top-level modules and a link to each mapped folder. ``mkdocs.yml`` points mkdocstrings there
(``paths: [build/griffe]``).
"""

from __future__ import annotations

import shutil
import tomllib
from pathlib import Path

from mkdocs.plugins import event_priority

ROOT = Path(__file__).resolve().parents[2]
TREE = ROOT / "build" / "griffe"


def lay_out_sources(root: Path = ROOT, tree: Path = TREE) -> Path:
    """Build ``tree/<package>/`` from the package-dir mapping of ``root/pyproject.toml``."""
    setuptools = tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"]
    package_dir: dict[str, str] = setuptools.get("package-dir", {})
    if tree.exists():
        shutil.rmtree(tree)
    tree.mkdir(parents=True)
    for package in sorted(setuptools["packages"], key=lambda name: name.count(".")):
        source = root / package_dir.get(package, package.replace(".", "/"))
        target = tree.joinpath(*package.split("."))
        if "." not in package:
            # the top package: copies of its modules (griffe lists the folder of __init__.py's real
            # path, so a link to it would lead griffe back to the source folder), links to the rest
            target.mkdir()
            for entry in source.iterdir():
                if entry.name == "__pycache__":
                    continue
                if entry.is_file():
                    shutil.copy2(entry, target / entry.name)
                else:
                    (target / entry.name).symlink_to(entry.resolve(), target_is_directory=True)
        elif not target.exists() and target.parent.resolve().is_relative_to(tree.resolve()):
            target.symlink_to(source.resolve(), target_is_directory=True)
    return tree


@event_priority(100)  # before mkdocstrings' on_config, which keeps only search paths that exist
def on_config(config, **kwargs):
    lay_out_sources()
    return config
