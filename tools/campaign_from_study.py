"""A campaign of one level of a verification study's runs (issue 45: the high-fidelity campaign of
the multi-fidelity discrepancy without solving again what the study solved).

The verification study (``indent-studio verify-study``) solves every level of the contact-L family
at its budget points and keeps each run (``<study>/R<radius>/c1-<c1>_c5-<c5>/L<k>-s1.npz``). Its
runs record the mesh as built by the family, not by preset name, so each one is checked first: its
top-surface nodes must be those the preset ``contact-L<k>`` builds (to 1e-9 mm), its protocol,
indenter, material and contact those of the campaign's model. Only then is it saved as the
campaign's point, with the preset's name in its spec and where it came from in the campaign's
record; a run that differs in anything is refused by name.

    .venv/bin/python tools/campaign_from_study.py --study /work/longruns/verif-R8 --radius 8 \\
        --level 3 --name L3-stick-R8 --runs-dir /work/longruns/camp
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import numpy as np

from indentation_studio.campaign.designs import Design
from indentation_studio.campaign.index import result_row
from indentation_studio.campaign.spec import CampaignSpec
from indentation_studio.campaign.store import CampaignStore
from indentation_studio.forward.mesh import build_mesh
from indentation_studio.forward.result import SimulationResult
from indentation_studio.forward.spec import Indenter, MeshChoice, ModelSpec, Protocol

POINT = re.compile(r"c1-([0-9.]+)_c5-([0-9.]+)$")


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--study", type=Path, required=True)
    parser.add_argument("--radius", type=float, required=True)
    parser.add_argument("--level", type=int, required=True)
    parser.add_argument("--name", required=True)
    parser.add_argument("--runs-dir", type=Path, default=Path("runs"))
    args = parser.parse_args()

    folder = args.study / f"R{args.radius:g}"
    runs = sorted(
        p for p in folder.iterdir() if POINT.match(p.name) and (p / f"L{args.level}-s1.npz").is_file()
    )
    if not runs:
        raise SystemExit(f"no level-{args.level} runs under {folder}")
    results = [SimulationResult.load(p / f"L{args.level}-s1.npz") for p in runs]
    first = results[0].spec
    model = ModelSpec(
        mesh=MeshChoice(f"contact-L{args.level}"),
        indenter=Indenter(args.radius),
        protocol=Protocol(step_size=first["protocol"]["step_size"], steps=first["protocol"]["steps"]),
    )
    expected = model.to_dict()
    mesh = build_mesh(model)
    top = mesh.nodes[mesh.top]
    theta = np.array([[float(POINT.match(p.name)[1]), float(POINT.match(p.name)[2])] for p in runs])
    for path, result, point in zip(runs, results, theta, strict=True):
        for key in ("geometry", "indenter", "protocol", "contact"):
            if result.spec[key] != expected[key]:
                raise SystemExit(
                    f"{path}: its {key} {result.spec[key]} is not the campaign's {expected[key]}"
                )
        if not np.allclose([result.spec["material"]["c1"], result.spec["material"]["c5"]], point):
            raise SystemExit(
                f"{path}: its material {result.spec['material']} is not its folder's point {point}"
            )
        if result.top_xyz.shape != top.shape or not np.allclose(result.top_xyz, top, atol=1e-9, rtol=0):
            raise SystemExit(f"{path}: its top nodes are not those contact-L{args.level} builds")
    design = Design(theta, ("c1", "c5"), f"the {len(runs)} points of {args.study}")
    spec = CampaignSpec(args.name, design, model, "embedded", {"adopted_from": str(args.study)})
    store = CampaignStore.create_or_open(args.runs_dir, spec)
    with store.locked():
        for i, (path, result) in enumerate(zip(runs, results, strict=True)):
            result.spec = model.with_parameters(c1=theta[i, 0], c5=theta[i, 1]).to_dict()
            result.solver = dict(result.solver) | {"adopted_from": str(path)}
            store.save_point(i, result, None, {"status": "done", **result_row(result)})
            print(f"point {i}: {path.name} (wall {result.wall_s:.0f} s when solved)")
        store.write_index()
    print(store.summary())


if __name__ == "__main__":
    main()
