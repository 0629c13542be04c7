"""Write a shipped field-error table from pairs of runs at two mesh levels (by hand; issue 57).

    .venv/bin/python tools/make_field_error_table.py --pair L3.npz:L4.npz [--pair ...] \\
        --out indentation_studio/error_budgets/field-error-R4.77.json

Each pair is one point's runs on the coarse level (the high fidelity the shipped surrogates are
corrected toward, contact-L3) and the fine one (contact-L4), of one test. The table
(``inference.adequacy.field_error``) is the largest over the pairs of the fine field less the
coarse one, root mean square by band of distance from the axis and step; the file records the
test (as the error budgets do), the two meshes, each pair's files, parameters, contact and code
version, and this tool's version.
"""

from __future__ import annotations

import argparse
import json
from datetime import UTC, datetime
from pathlib import Path

from indentation_studio import __version__
from indentation_studio.forward.result import SimulationResult
from indentation_studio.inference.adequacy.field_error import field_error_table
from indentation_studio.surrogate.error_budgets import indentation_test_of


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pair", action="append", required=True, help="COARSE.npz:FINE.npz")
    ap.add_argument("--out", required=True)
    ap.add_argument(
        "--meshes",
        help="COARSE:FINE mesh names for pairs whose spec does not name its mesh (a verification study's "
        "family levels), checked against the named runs' top nodes",
    )
    args = ap.parse_args()
    pairs, sources, tests, meshes = [], [], [], set()
    for pair in args.pair:
        coarse_path, fine_path = pair.split(":")
        coarse, fine = SimulationResult.load(coarse_path), SimulationResult.load(fine_path)
        pairs.append((coarse, fine))
        for run in (coarse, fine):
            tests.append(json.dumps(indentation_test_of(run.spec), sort_keys=True))
        named = tuple(run.spec["mesh"]["preset"] for run in (coarse, fine))
        sizes = tuple(len(run.top_xyz) for run in (coarse, fine))
        if named == ("default", "default") and args.meshes:  # a study's family levels
            named = tuple(args.meshes.split(":"))
        meshes.add((named, sizes))
        sources.append(
            {
                "coarse": str(Path(coarse_path).resolve()),
                "fine": str(Path(fine_path).resolve()),
                "c1_c5": [coarse.spec["material"]["c1"], coarse.spec["material"]["c5"]],
                "versions": [coarse.solver.get("version"), fine.solver.get("version")],
            }
        )
    if len(set(tests)) != 1:
        raise SystemExit("the runs are not all of one test (geometry, indenter, protocol, contact, material)")
    if len(meshes) != 1:
        raise SystemExit(f"the pairs are not all of the same two meshes (names, top nodes): {sorted(meshes)}")
    ((coarse_mesh, fine_mesh), _), spec = meshes.pop(), pairs[0][0].spec
    radius = spec["indenter"]["radius"]
    table = field_error_table(pairs, radius)
    table["rms_mm"] = [
        [[round(v, 6) for v in band] for band in step] for step in table["rms_mm"]
    ]  # a micrometre
    payload = {
        "description": (
            f"The field error of {coarse_mesh} against {fine_mesh} at {len(pairs)} points of the test with "
            f"R = {radius:g} mm: the root mean square of the fine run's top field less the "
            "coarse one's by band of distance from the axis and step, the largest over the points "
            "(inference.adequacy.field_error; docs/validation/model-error.md)"
        ),
        "test": json.loads(tests[0]),
        "coarse_mesh": coarse_mesh,
        "fine_mesh": fine_mesh,
        "pairs": sources,
        "made": {
            "by": "tools/make_field_error_table.py",
            "version": __version__,
            "at": datetime.now(UTC).isoformat(),
        },
    } | table
    Path(args.out).write_text(json.dumps(payload, indent=1) + "\n")
    print(
        f"wrote {args.out}: {len(pairs)} pairs, {len(table['depths'])} depths, {coarse_mesh} against {fine_mesh}"
    )


if __name__ == "__main__":
    main()
