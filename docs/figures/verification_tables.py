"""Markdown tables of a verification study's ``study.json`` (for docs/validation/verification.md).

.venv/bin/python docs/figures/verification_tables.py runs/verification/baseline/study.json
"""

from __future__ import annotations

import sys

from indentation_studio.inference.budgets.study_files import load_verification_study


def fmt(v: float, digits: int = 4) -> str:
    return "nan" if v is None or v != v else f"{v:.{digits}g}"


def main(path: str) -> None:
    study = load_verification_study(path)
    fam = study["family"]
    print(f"Family `{fam['name']}`, levels {study['levels']} (finest first).\n")
    for case in study["cases"]:
        levels = case["levels"]
        print(
            f"### R = {case['radius']:g} mm, (c1, c5) = ({case['theta'][0]:g}, {case['theta'][1]:g}) kPa\n\n"
            + "Levels: "
            + ", ".join(f"{lv['nodes']:,} nodes ({lv['wall_s']:.0f} s)" for lv in levels)
            + "\n"
        )
        print("| quantity | values, finest first | orders p | asymptotic | extrapolated | GCI % per level |")
        print("| --- | --- | --- | --- | --- | --- |")
        for name, q in case["quantities"].items():
            print(
                f"| {name} | {', '.join(fmt(v) for v in q['values'])} | "
                f"{', '.join(fmt(p, 3) for p in q['orders'])} | {'yes' if q['asymptotic'] else 'no'} | "
                f"{fmt(q['extrapolated'])} | {', '.join(fmt(g, 3) for g in q['gci_pct'])} |"
            )
        for inc in case.get("increments", []):
            print(
                f"\nIncrements on level {inc['level']}: substeps {inc['substeps']}, force at the deepest step "
                f"{', '.join(fmt(f, 6) for f in inc['force_deepest_mN'])} mN, order {fmt(inc['order'], 3)}, "
                f"GCI {fmt(inc['gci_pct'], 3)} %"
            )
        print()


if __name__ == "__main__":
    main(sys.argv[1])
