"""Read a markdown table of a validation page: the page is the record, a figure drawn from it adds
no number of its own (not a maker: the makers beside it import it)."""

from __future__ import annotations

import re
from pathlib import Path

VALIDATION = Path(__file__).resolve().parents[1] / "validation"
FIGURES = VALIDATION / "figures"


def page_table(page: str, header_starts: str) -> list[dict[str, str]]:
    """The rows of the first table of ``validation/<page>.md`` whose header starts with ``header_starts``."""
    lines = (VALIDATION / f"{page}.md").read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(f"| {header_starts}"))
    header = _cells(lines[start])
    rows = []
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        rows.append(dict(zip(header, _cells(line), strict=False)))
    return rows


def _cells(line: str) -> list[str]:
    """A row's cells, split at ' | ' (a cell may hold a bar, as ||dF||)."""
    return [cell.strip() for cell in line.strip()[2:-2].split(" | ")]


def number(text: str) -> float:
    """The first number in a cell ('1,452' -> 1452, '+2.2 %' -> 2.2, '-0.06 / -33.6 %' -> -0.06)."""
    return float(re.search(r"[-+]?\d[\d,]*\.?\d*", text).group().replace(",", ""))
