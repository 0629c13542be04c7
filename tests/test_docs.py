"""The documentation site builds offline in strict mode: broken links, missing anchors and API
cross-references that do not resolve fail the build (mkdocs.yml, docs/)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_docs_build_strict(tmp_path):
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    mkdocs = [sys.executable, "-m", "mkdocs", "build", "--strict", "-q", "-f", str(ROOT / "mkdocs.yml")]
    run = subprocess.run(
        [*mkdocs, "-d", str(tmp_path / "site")], cwd=ROOT, env=env, capture_output=True, text=True
    )
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-4000:]
    site = tmp_path / "site"
    # a user-guide page, a validation page, the API reference and a notebook are there
    for page in ("guide/simulate", "validation/friction", "api/forward", "notebooks/01_forward_model"):
        assert (site / page / "index.html").is_file(), page
    api = (site / "api" / "forward" / "index.html").read_text()
    assert 'id="indentation_studio.forward.ModelSpec"' in api  # the lazily exported names resolved


def test_docs_home_shows_the_readme_commands():
    readme = (ROOT / "README.md").read_text()
    home = (ROOT / "docs" / "index.md").read_text()
    commands = [line for line in readme.splitlines() if line.startswith("python3 -m venv ")]
    assert len(commands) == 2 and all(command in home.splitlines() for command in commands)
