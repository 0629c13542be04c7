"""Help texts as a terminal shows them: the commands' docstrings without the reStructuredText a
terminal does not render (double backticks, ``:func:`` roles), a one-sentence line in the command
list, the guide page of each command (a page under ``docs/guide/`` that exists: the test over
every command's ``--help`` checks both), and the panels of ``indent-studio --help`` that list the
commands in a user's order (:data:`COMMAND_PANELS`)."""

from __future__ import annotations

import inspect
import re

import typer

#: The guide page (``docs/guide/<page>.md``) of each top-level command or command group.
GUIDE_PAGES = {
    "fit": "fit-and-posterior",
    "posterior": "fit-and-posterior",
    "confirm": "fit-and-posterior",
    "check": "import-and-check",
    "import": "import-and-check",
    "verification-study": "simulate",
    "simulate": "simulate",
    "export-feb": "febio",
    "mesh-study": "simulate",
    "demo": "demo",
    "test": "own-test",
    "campaign": "campaign",
    "composite": "composite",
    "design": "design",
    "surrogate": "surrogates",
}
#: a command of ``import`` whose page is another
_SUB_PAGES = {("import", "febio"): "febio"}

#: The panels of ``indent-studio --help`` (typer's ``rich_help_panel``) and their top-level
#: commands, in a user's order: the demo first, then what is decided before a test, what is done
#: after one, the models and campaigns under both, and the tools.
COMMAND_PANELS = {
    "Start here": ("demo",),
    "Before a test": ("design", "test"),
    "After a test": ("import", "check", "fit", "posterior", "confirm"),
    "Models and campaigns": (
        "simulate",
        "campaign",
        "surrogate",
        "mesh-study",
        "verification-study",
        "composite",
    ),
    "Tools": ("export-feb",),
}
#: The top-level commands in the order ``indent-studio --help`` lists them.
COMMAND_ORDER = tuple(name for names in COMMAND_PANELS.values() for name in names)

_ROLE = re.compile(r":(?:func|mod|class|meth|data|attr|ref|doc):`~?([^`<]+?)(?:\s*<[^>]*>)?`")
#: the longest line a command gets in its group's list
SHORT_HELP_CHARS = 100


def plain(text: str) -> str:
    """``text`` without reStructuredText markup: ``x`` and :func:`x` become x."""
    return _ROLE.sub(r"\1", text).replace("``", "")


def first_sentence(text: str, limit: int = SHORT_HELP_CHARS) -> str:
    """The first sentence of ``text``'s first paragraph, cut at a word to ``limit`` characters."""
    para = " ".join(text.strip().split("\n\n")[0].split())
    depth, end = 0, len(para)
    for i, ch in enumerate(para):
        depth += ch in "([{"
        depth -= ch in ")]}"
        after = para[i + 2 : i + 3]  # a sentence ends at a full stop before a capital (not "eq. 9", "e.g. x")
        if ch == "." and depth == 0 and (i + 1 == len(para) or (para[i + 1] == " " and after.isupper())):
            end = i + 1
            break
    sentence = para[:end]
    if len(sentence) <= limit:
        return sentence
    return sentence[: limit - 3].rsplit(" ", 1)[0].rstrip(",;:") + "..."


def guide_page(path: tuple[str, ...]) -> str:
    """The guide page (``docs/guide/<page>.md``) of the command at ``path`` (e.g. ("import", "csv"))."""
    return f"docs/guide/{_SUB_PAGES.get(path[:2], GUIDE_PAGES[path[0]])}.md"


def _command_name(info: typer.models.CommandInfo) -> str:
    """The name a registered command has on the command line (its function's, dashed, unless given)."""
    return info.name or info.callback.__name__.replace("_", "-")


def tidy_help(app: typer.Typer, path: tuple[str, ...] = ()) -> None:
    """Give every command of ``app`` (and of its groups) a plain help text ending with its guide
    page, and a one-sentence line in its group's command list."""
    for info in app.registered_commands:
        name = _command_name(info)
        text = plain(
            inspect.cleandoc(info.help if isinstance(info.help, str) else (info.callback.__doc__ or ""))
        )
        text = "\n\n".join(p.strip() for p in text.strip().split("\n\n"))
        info.help = f"{text}\n\nGuide: {guide_page((*path, name))}"
        info.short_help = first_sentence(text)
    for group in app.registered_groups:
        sub = group.typer_instance
        tidy_help(sub, (*path, group.name))
        text = plain(sub.info.help if isinstance(sub.info.help, str) else "")
        sub.info.help = f"{text}\n\nGuide: {guide_page((*path, group.name))}"
        sub.info.short_help = first_sentence(text)


def place_commands(app: typer.Typer) -> None:
    """Put each top-level command and command group of ``app`` in its panel of :data:`COMMAND_PANELS`
    (one not named there stays in typer's default panel, "Commands")."""
    panel = {name: title for title, names in COMMAND_PANELS.items() for name in names}
    for info in app.registered_commands:
        info.rich_help_panel = panel.get(_command_name(info))
    for group in app.registered_groups:
        group.rich_help_panel = panel.get(group.name)
