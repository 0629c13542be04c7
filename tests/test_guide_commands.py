"""The guide's commands run as written, in order, after the README's first command: the ``bash``
blocks of docs/guide/import-and-check.md and then of docs/guide/fit-and-posterior.md marked
``<!-- runs in tests/test_guide_commands.py -->`` (a newcomer's first hour; not the campaigns on
the reference mesh further down), from a folder holding the repository's ``examples/``. The demo's surrogate
(``runs/demo/surrogate-mlp.safetensors``) stands in as a 9-point GP on the coarse mesh, ``check``
runs on the coarse mesh and ``fit`` without its FE stage (``--no-refine``: minutes of FE runs with mu
marginalised), as the pages say."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest
from typer.testing import CliRunner

from indentation_studio.campaign.runner import run_named_campaign
from indentation_studio.forward.spec import MeshChoice, ModelSpec
from indentation_studio.studio.cli import app
from indentation_studio.surrogate.persistence import save_surrogate
from indentation_studio.surrogate.training import train_surrogate

ROOT = Path(__file__).resolve().parents[1]
PAGES = ("docs/guide/import-and-check.md", "docs/guide/fit-and-posterior.md")


def commands(page: str) -> list[list[str]]:
    """The commands of a page's marked ``bash`` blocks: continuation lines joined, comments dropped."""
    out = []
    marked = r"<!-- runs in tests/test_guide_commands.py -->\n```bash\n(.*?)```"
    for block in re.findall(marked, (ROOT / page).read_text(), flags=re.S):
        for line in block.replace("\\\n", " ").splitlines():
            line = line.split(" #")[0].strip()
            if line and not line.startswith("#"):
                out.append(shlex.split(line))
    return out


def test_the_pages_have_no_placeholders():
    for page in PAGES:
        for argv in commands(page):
            assert argv[0] == "indent-studio", argv
            text = " ".join(argv)
            for placeholder in ("EXP", "...", "runs/paper/", "exp/", "record.csv"):
                assert placeholder not in argv and placeholder not in text.split(), (page, text)
            for arg in argv:
                if arg.startswith("examples/"):
                    assert (ROOT / arg).exists(), arg
    assert any("examples/lab-matchid/matchid" in argv for argv in commands(PAGES[0]))
    assert [argv[1] for argv in commands(PAGES[1])] == ["fit", "posterior", "confirm"]


@pytest.mark.slow
def test_the_guide_runs_as_written(tmp_path, monkeypatch):
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    monkeypatch.chdir(tmp_path)
    spec = ModelSpec(mesh=MeshChoice("coarse"))
    # one process: the suite's two workers already take CI's two cores
    run_named_campaign("standin", "c1=8:16:3,c5=150:350:3", spec, runs_dir="runs", jobs=1)
    save_surrogate(
        train_surrogate("standin", "gp", runs_dir="runs"), Path("runs/demo/surrogate-mlp.safetensors")
    )
    for page in PAGES:
        for argv in commands(page):
            if argv[1] == "check":
                argv = [*argv, "--mesh", "coarse"]
            if argv[1] == "fit":
                argv = [*argv, "--no-refine"]
            res = CliRunner().invoke(app, argv[1:])
            assert res.exit_code == 0, f"{' '.join(argv)}\n{res.output}"
    assert Path("runs/lab/check/index.html").is_file() and Path("runs/lab-force.csv").is_file()
