"""MkDocs hook: the notebooks of ``notebooks/`` as pages of the site, under ``notebooks/``.

The notebooks stay where the tests run them; this hook adds each one to the site's files before
mkdocs-jupyter turns them into pages (rendered as stored: ``execute: false`` in ``mkdocs.yml``).
"""

from __future__ import annotations

from pathlib import Path

from mkdocs.plugins import event_priority
from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[2]


@event_priority(100)  # before mkdocs-jupyter's on_files, which wraps every .ipynb it is given
def on_files(files, config, **kwargs):
    for notebook in sorted((ROOT / "notebooks").glob("*.ipynb")):
        path = f"notebooks/{notebook.name}"
        if files.get_file_from_path(path) is None:
            files.append(
                File(
                    path,
                    src_dir=str(ROOT),
                    dest_dir=config["site_dir"],
                    use_directory_urls=config["use_directory_urls"],
                )
            )
    return files
