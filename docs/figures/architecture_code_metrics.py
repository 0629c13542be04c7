"""Counts a newcomer's reading of the code rests on, read with ``ast`` (nothing is imported):
the package's modules (how many, their lines, the median and the largest, those over 400 lines,
``inference/``'s share, the top-level names defined in more than one module), the longest CLI
commands (lines of each ``@...command`` function with its decorators), the calls that pass 8 or
more positional arguments (library, tests, benchmarks, tools and the docs' makers), and the
imports of the project's own modules placed inside functions (``tests/test_layers.py`` holds
their ratchet).

    .venv/bin/python docs/figures/architecture_code_metrics.py [--longest 8]
    .venv/bin/python docs/figures/architecture_code_metrics.py --rev 16d5a7f

``--rev`` prints the modules' figures only, read as that commit holds them (``git show``), for a
before and after; without it every count reads the working tree.
"""

from __future__ import annotations

import argparse
import ast
import statistics
import subprocess
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("forward", "campaign", "surrogate", "design", "inference", "studio", "indentation_studio")


def _trees(folders: tuple[str, ...]):
    for folder in folders:
        for path in sorted((ROOT / folder).rglob("*.py")):
            yield path.relative_to(ROOT), ast.parse(path.read_text())


def _package_sources(rev: str | None = None) -> dict[str, str]:
    """'package/.../module.py' -> source, of every module of the package, in the working tree or,
    with ``rev``, as that commit holds them."""
    if rev is None:
        return {
            str(path.relative_to(ROOT)): path.read_text()
            for folder in PACKAGES
            for path in sorted((ROOT / folder).rglob("*.py"))
        }
    git = ["git", "-C", str(ROOT)]
    names = subprocess.run(
        [*git, "ls-tree", "-r", "--name-only", rev, "--", *PACKAGES],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    return {
        name: subprocess.run(
            [*git, "show", f"{rev}:{name}"], capture_output=True, text=True, check=True
        ).stdout
        for name in names
        if name.endswith(".py")
    }


def module_sizes(rev: str | None = None, over: int = 400) -> dict:
    """The review's figures of the package's modules: how many, their lines, the median and the
    largest, those over ``over`` lines (largest first), ``inference/``'s share of the lines, and the
    top-level functions and classes whose name is defined in more than one module."""
    sources = _package_sources(rev)
    lines = {name: len(text.splitlines()) for name, text in sources.items()}
    defined = Counter()
    where: dict[str, list[str]] = {}
    for name, text in sources.items():
        for node in ast.parse(text).body:
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                defined[node.name] += 1
                where.setdefault(node.name, []).append(name)
    inference = [n for n in lines if n.startswith("inference/")]
    largest = max(lines, key=lines.get)
    return {
        "modules": len(lines),
        "lines": sum(lines.values()),
        "median": statistics.median(lines.values()),
        "largest": (lines[largest], largest),
        "over": sorted(((n, name) for name, n in lines.items() if n > over), reverse=True),
        "inference_modules": len(inference),
        "inference_share": sum(lines[n] for n in inference) / sum(lines.values()),
        "defined_twice": {name: where[name] for name, count in sorted(defined.items()) if count > 1},
    }


def print_sizes(rev: str | None = None) -> None:
    """Print :func:`module_sizes` (at ``rev``, or the working tree)."""
    sizes = module_sizes(rev)
    print(f"package modules at {rev or 'the working tree'}: {sizes['modules']}, {sizes['lines']:,} lines")
    print(f"  median {sizes['median']:g} lines, largest {sizes['largest'][0]} ({sizes['largest'][1]})")
    print(f"  over 400 lines: {len(sizes['over'])}")
    for n, name in sizes["over"]:
        print(f"    {n:5d}  {name}")
    print(
        f"  inference/: {sizes['inference_modules']} modules, {sizes['inference_share']:.0%} of the package's lines"
    )
    print(f"  top-level names defined in more than one module: {len(sizes['defined_twice'])}")
    for name, places in sizes["defined_twice"].items():
        print(f"    {name}: {', '.join(places)}")


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
    parser.add_argument(
        "--rev", default=None, help="print the modules' figures only, as this commit holds them"
    )
    args = parser.parse_args()
    print_sizes(args.rev)
    if args.rev:
        return
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
