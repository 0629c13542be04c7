"""Counts a newcomer's reading of the code rests on, read with ``ast`` (nothing is imported):
the longest CLI commands (lines of each ``@...command`` function with its decorators), the calls
that pass 8 or more positional arguments (library, tests, benchmarks, tools and the docs' makers), and the imports of the
project's own modules placed inside functions (``tests/test_layers.py`` holds their ratchet).

    .venv/bin/python docs/figures/architecture_code_metrics.py [--longest 8]
"""

from __future__ import annotations

import argparse
import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("forward", "campaign", "surrogate", "design", "inference", "studio", "indentation_studio")


def _trees(folders: tuple[str, ...]):
    for folder in folders:
        for path in sorted((ROOT / folder).rglob("*.py")):
            yield path.relative_to(ROOT), ast.parse(path.read_text())


def command_lengths() -> list[tuple[int, str]]:
    """(lines, 'file:line name') of every typer command, longest first."""
    rows = []
    for path, tree in _trees(("studio",)):
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef) and any(
                "command" in ast.unparse(d) for d in node.decorator_list
            ):
                lines = node.end_lineno - node.lineno + 1 + len(node.decorator_list)
                rows.append((lines, f"{path}:{node.lineno} {node.name}"))
    return sorted(rows, reverse=True)


def positional_calls(at_least: int = 8) -> list[str]:
    """'file:line callee (n)' of every call with ``at_least`` positional arguments or more."""
    rows = []
    for path, tree in _trees((*PACKAGES, "tests", "benchmarks", "tools", "docs/figures")):
        for node in ast.walk(tree):
            if isinstance(node, ast.Call):
                n = sum(1 for a in node.args if not isinstance(a, ast.Starred))
                if n >= at_least:
                    rows.append(f"{path}:{node.lineno} {ast.unparse(node.func)} ({n})")
    return rows


def imports_inside_functions() -> list[str]:
    """'file:line import' of every import of the project's own modules inside a function."""
    rows = []
    for path, tree in _trees(PACKAGES):
        for fn in ast.walk(tree):
            if not isinstance(fn, ast.FunctionDef | ast.AsyncFunctionDef):
                continue
            for node in ast.walk(fn):
                own = isinstance(node, ast.ImportFrom) and (
                    node.level > 0 or (node.module or "").startswith("indentation_studio")
                )
                if own:
                    rows.append(f"{path}:{node.lineno} {ast.unparse(node)}")
    return sorted(set(rows))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--longest", type=int, default=8, help="how many of the longest commands to list")
    args = parser.parse_args()
    commands = command_lengths()
    over = sum(1 for lines, _ in commands if lines > 40)
    print(f"CLI commands: {len(commands)}, longer than 40 lines: {over}")
    for lines, where in commands[: args.longest]:
        print(f"  {lines:4d}  {where}")
    calls = positional_calls()
    library = [c for c in calls if not c.startswith(("tests", "benchmarks", "tools", "docs"))]
    print(f"calls with 8 or more positional arguments: {len(calls)} ({len(library)} in the library)")
    for c in calls:
        print(f"  {c}")
    inside = imports_inside_functions()
    print(f"imports of the project's own modules inside functions: {len(inside)}")
    for c in inside:
        print(f"  {c}")


if __name__ == "__main__":
    main()
