"""Write a shipped mesh-differences file from pairs of runs at two mesh levels (by hand; issue 57).

    .venv/bin/python tools/make_mesh_differences.py --pair L3.npz:L4.npz [--pair ...] \\
        --surrogate indentation_studio/surrogates/paper-test-R4.77.safetensors \\
        --meshes contact-L3:contact-L4 --out indentation_studio/error_budgets/mesh-differences-R4.77.npz

Each pair is one error-budget point's runs on the fit's high fidelity (contact-L3) and on the
budget's reference level (contact-L4), of one test with the stick. The file keeps the coarse
outputs less the fine ones (log force per step, the top field at the surrogate's nodes), so that a
fit freeing mu moves them through its own parameters
(``inference.budgets.freed_mu_moves``); it records the test (the coarse run's spec, its mesh named),
each pair's files, parameters and code versions, and this tool's version.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from indentation_studio import __version__
from indentation_studio.forward.convergence.mesh_family import contact_mesh
from indentation_studio.forward.result import SimulationResult
from indentation_studio.inference.budgets.mesh_difference_runs import mesh_differences_from_runs
from indentation_studio.surrogate.error_budgets import indentation_test_of
from indentation_studio.surrogate.persistence import load_surrogate


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pair", action="append", required=True, help="COARSE.npz:FINE.npz")
    ap.add_argument("--surrogate", required=True, help="the surrogate whose top nodes the field is kept at")
    ap.add_argument(
        "--meshes", required=True, help="COARSE:FINE contact mesh presets (contact-L3:contact-L4)"
    )
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    names = args.meshes.split(":")
    pairs, runs, tests = [], [], set()
    for pair in args.pair:
        paths = pair.split(":")
        coarse, fine = (SimulationResult.load(p) for p in paths)
        radius = coarse.spec["indenter"]["radius"]
        for run, name in zip((coarse, fine), names, strict=True):
            nodes = int(run.solver["mesh"]["nodes"])
            expected = contact_mesh(name, radius).nodes.shape[0]
            if nodes != expected:
                raise SystemExit(
                    f"{pair}: a run has {nodes} nodes, {name} at R = {radius:g} mm has {expected}"
                )
            run.spec["mesh"] = dict(run.spec.get("mesh") or {}) | {"preset": name}
            tests.add(json.dumps(indentation_test_of(run.spec), sort_keys=True))
        pairs.append((coarse, fine))
        runs.append(
            {
                "coarse": str(Path(paths[0]).resolve()),
                "fine": str(Path(paths[1]).resolve()),
                "c1_c5": [coarse.spec["material"]["c1"], coarse.spec["material"]["c5"]],
                "versions": [coarse.solver.get("version"), fine.solver.get("version")],
            }
        )
    if len(tests) != 1:
        raise SystemExit("the runs are not all of one test (geometry, indenter, protocol, contact, material)")
    surrogate = load_surrogate(args.surrogate)
    differences = mesh_differences_from_runs(pairs, surrogate.top_xyz, runs=runs, version=__version__)
    differences.meta["made"]["by"] = "tools/make_mesh_differences.py"
    differences.meta["surrogate"] = str(args.surrogate)
    differences.save(args.out)
    print(
        f"wrote {args.out}: {len(pairs)} points, {names[0]} less {names[1]}, {len(surrogate.top_xyz)} top nodes"
    )


if __name__ == "__main__":
    main()
