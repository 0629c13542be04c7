"""Level 4 against level 3, and the three options for the error budgets' reference (issue 45).

First a table of the fitted c1 and c5 on every level with their observed orders, level 3's
distance to level 4 and level 3's c5 GCI from levels 3-2-1; then, for every point of a verification study whose finest level is contact-L4, the fitted c1 and c5
budget's model-error part under:

(a) level 3 as the reference, with ``inference.reference_uncertainty_pct`` (its GCI, never less
    than its distance to level 4 plus level 4's own);
(b) level 4 as the reference: level 3's fit corrected by the measured level 3 -> 4 difference,
    only level 4's GCI carried;
(c) as (b), corrected to the extrapolated value where the finest triplet is monotone (the
    correction's size shown), level 4's GCI carried.

.venv/bin/python benchmarks/probes/budget_reference_options.py /work/longruns/verif-R8/study.json [...]
"""

from __future__ import annotations

import sys

from indentation_studio.inference import reference_uncertainty_pct
from indentation_studio.inference.budgets.study_files import load_verification_study


def _level4_cases(path: str) -> list[dict]:
    """The study's points whose finest level is level 4."""
    return [c for c in load_verification_study(path)["cases"] if c["levels"][0]["level"] == 4]


def level_rows(path: str) -> list[str]:
    """Fitted c1 and c5 on levels 4 to 0, orders, level 3 from level 4, level 3's c5 GCI."""
    out = []
    for case in _level4_cases(path):
        cells = []
        for p, digits in (("c1", 3), ("c5", 1)):
            q = case["quantities"][f"fit {p}"]
            cells += [
                ", ".join(f"{x:.{digits}f}" for x in q["values"]),
                ", ".join(f"{o:.2f}" for o in q["orders"]),
                f"{100.0 * (q['values'][1] / q['values'][0] - 1.0):+.2f} %",
            ]
        cells.append(f"{case['quantities']['fit c5']['gci_pct'][1]:.2f} %")
        out.append(f"| {case['theta'][0]:g}, {case['theta'][1]:g} | " + " | ".join(cells) + " |")
    return out


def rows(path: str) -> list[str]:
    """The model-error part of c1 and c5 under options (a) and (b), and the corrections."""
    out = []
    for case in _level4_cases(path):
        cells = []
        for p in ("c1", "c5"):
            q = case["quantities"][f"fit {p}"]
            v, h = q["values"], q["sizes"]
            a = reference_uncertainty_pct(v, h, 1)
            b = reference_uncertainty_pct(v, h, 0)
            shift = 100.0 * (v[0] - v[1]) / v[1]  # the correction (b) applies to level 3's fit
            ext = q["extrapolated"]
            to_ext = (
                100.0 * (ext - v[0]) / v[0] if ext == ext and not q["triplets"][0]["oscillatory"] else None
            )
            cells += [
                f"{a:.2f}",
                f"{shift:+.2f}",
                f"{b:.2f}",
                "oscillates" if to_ext is None else f"{to_ext:+.2f}",
            ]
        out.append(
            f"| {case['radius']:g} | {case['theta'][0]:g}, {case['theta'][1]:g} | " + " | ".join(cells) + " |"
        )
    return out


def main(paths: list[str]) -> None:
    print(
        "| (c1, c5) kPa | fit c1, levels 4 to 0 | c1 orders | level 3 from level 4 "
        "| fit c5, levels 4 to 0 | c5 orders | level 3 from level 4 | level 3's c5 GCI (Celik, levels 3-2-1) |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for path in paths:
        print("\n".join(level_rows(path)))
    print()
    print(
        "| R mm | c1, c5 kPa | c1 (a) % | c1 (b)'s correction % | c1 (b) % | c1 (c)'s further correction % "
        "| c5 (a) % | c5 (b)'s correction % | c5 (b) % | c5 (c)'s further correction % |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for path in paths:
        print("\n".join(rows(path)))


if __name__ == "__main__":
    main(sys.argv[1:])
