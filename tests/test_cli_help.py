"""The command line's conventions: every command's --help is plain text (no reStructuredText
markup a terminal does not render) and names a guide page that exists; usage errors are usage
errors (click's usage line, the missing option, exit code 2, "did you mean")."""

from pathlib import Path

import pytest
from typer.main import get_command
from typer.testing import CliRunner

from indentation_studio.studio.cli import app
from indentation_studio.studio.help_text import COMMAND_ORDER, COMMAND_PANELS, first_sentence, plain

ROOT = Path(__file__).resolve().parents[1]
runner = CliRunner()


def _commands(command, path=()):
    yield path
    for name, sub in getattr(command, "commands", {}).items():
        yield from _commands(sub, (*path, name))


COMMANDS = [p for p in _commands(get_command(app)) if p]


def test_every_command_is_listed():
    assert len(COMMANDS) >= 35 and ("import", "load-frame") in COMMANDS and ("fit",) in COMMANDS


@pytest.mark.parametrize("path", COMMANDS, ids=" ".join)
def test_help_is_plain_and_names_a_guide_page(path):
    res = runner.invoke(app, [*path, "--help"], env={"COLUMNS": "200"})
    assert res.exit_code == 0, res.output
    for markup in ("``", ":func:", ":mod:", ":class:", "README"):
        assert markup not in res.output, f"{' '.join(path)} --help shows {markup!r}"
    pages = [w.strip(".,;)") for w in res.output.split() if w.startswith("docs/guide/")]
    assert pages, f"{' '.join(path)} --help names no guide page"
    for page in pages:
        assert (ROOT / page).is_file(), f"{' '.join(path)} --help names {page}, which does not exist"


def test_command_list_shows_one_sentence():
    res = runner.invoke(app, ["--help"], env={"COLUMNS": "200"})
    assert res.exit_code == 0
    line = next(v for v in res.output.splitlines() if " check " in v)
    assert "The data check before any fit: holds and their eq. 9 fits" in line and "registration" not in line


def test_command_list_is_in_a_users_order():
    """``indent-studio --help`` starts with the demo and groups the commands in panels (before a
    test, after a test, models and campaigns, tools); every command is in one panel, once."""
    res = runner.invoke(app, ["--help"], env={"COLUMNS": "200"})
    assert res.exit_code == 0
    lines = res.output.splitlines()
    panels = [line.strip("╭─ ").split(" ─")[0] for line in lines if line.startswith("╭─")]
    assert panels == ["Options", *COMMAND_PANELS]
    listed = [line.split()[1] for line in lines if line.startswith("│ ") and not line.startswith("│ --")]
    assert listed == list(COMMAND_ORDER) and listed[0] == "demo"
    assert sorted(listed) == sorted({path[0] for path in COMMANDS})


def test_plain_and_first_sentence():
    assert plain("``--friction MU`` and :func:`.force_onset`") == "--friction MU and .force_onset"
    assert first_sentence("Fits eq. 9 to each hold. Then more.") == "Fits eq. 9 to each hold."
    assert first_sentence("word " * 40).endswith("...") and len(first_sentence("word " * 40)) <= 100


def test_missing_option_is_a_usage_error():
    res = runner.invoke(app, ["fit"])
    assert res.exit_code == 2
    assert "Usage: root fit [OPTIONS]" in res.output and "Missing option '--experiment'" in res.output
    assert "unexpected" not in res.output


def test_mistyped_command_is_a_usage_error():
    res = runner.invoke(app, ["fitt"])
    assert res.exit_code == 2
    assert "No such command 'fitt'" in res.output and "Did you mean 'fit'?" in res.output
    assert "unexpected" not in res.output


def test_help_into_a_closed_pipe_is_quiet(monkeypatch):
    """``indent-studio import --help | head -20``: the reader stops before the help is written
    (a BrokenPipeError, as rich writes the rest); no 'unexpected' error, exit 0."""
    import typer.rich_utils

    def closed(*args, **kwargs):
        raise BrokenPipeError(32, "Broken pipe")

    monkeypatch.setattr(typer.rich_utils, "rich_format_help", closed)
    res = runner.invoke(app, ["import", "--help"])
    assert res.exit_code == 0 and "unexpected" not in res.output and "BrokenPipe" not in res.output
