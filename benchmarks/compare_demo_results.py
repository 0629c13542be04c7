"""Compare two demo reports' ``results.json`` (by hand: a refactoring must leave the demo's
numbers as they were): Table 1 rows, the fit, the posterior median, the confirmation, the
surrogates' test errors, to 4 significant figures.

    .venv/bin/python benchmarks/compare_demo_results.py OLD/runs/demo/report/results.json NEW/runs/demo/report/results.json

Exits 1 when a number differs at 4 significant figures.
"""

from __future__ import annotations

import json
import sys


def sig4(values) -> list[str]:
    return [f"{float(v):.4g}" for v in values]


def rows(results: dict) -> dict[str, list[str]]:
    out = {}
    for row in results["table1"]:
        out[f"Table 1, {row['name']}: c1 %, c5 %"] = sig4([row["c1_pct"], row["c5_pct"]])
        out[f"Table 1, {row['name']}: weights"] = sig4(row["weights"])
    out["fit theta"] = sig4(results["fit"]["theta"])
    out["fit bounds %"] = sig4(results["fit"]["bounds_pct"])
    out["posterior median"] = sig4(results["posterior"]["median"])
    out["confirmation F"] = sig4([results["confirmation"]["F_fe"], results["confirmation"]["F_fit"]])
    for kind, err in results["surrogate_test_errors"].items():
        out[f"surrogate {kind} force rms %"] = sig4([err["force_rms_pct"]])
    return out


def main(old_path: str, new_path: str) -> int:
    old, new = (rows(json.load(open(p))) for p in (old_path, new_path))
    differ = 0
    for key in old.keys() | new.keys():
        same = old.get(key) == new.get(key)
        differ += not same
        print(f"{'same' if same else 'DIFFERS'}  {key}: {old.get(key)} -> {new.get(key)}")
    print(f"{differ} of {len(old.keys() | new.keys())} differ at 4 significant figures")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:3]))
