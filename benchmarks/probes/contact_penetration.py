"""How far the sphere cuts into the block's top faces between the points where the contact holds
them: for each result file, at every ``--every``-th step, the force, the smallest gap of the top
nodes to the sphere and of ``--order`` x ``--order`` points on every top face (the faces'
bilinear interpolation of the nodes, as ``forward.contact_quadrature`` places them), and the area
of the face points inside the sphere. A node-wise contact holds only the nodes, so on a coarse
top the faces between them may pass into the sphere; a surface contact holds its Gauss points.

    .venv/bin/indent-studio simulate --mesh composite-coarse --out runs/pen/node.npz
    .venv/bin/indent-studio simulate --mesh composite-coarse --contact surface --contact-order 3 --out runs/pen/surface3.npz
    .venv/bin/python benchmarks/probes/contact_penetration.py runs/pen/node.npz runs/pen/surface3.npz
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from indentation_studio.forward.contact_quadrature import contact_points
from indentation_studio.forward.mesh import build_mesh
from indentation_studio.forward.result import SimulationResult
from indentation_studio.forward.spec import ModelSpec


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("results", type=Path, nargs="+", help="simulation result files (.npz)")
    parser.add_argument("--order", type=int, default=4, help="points per face edge where the gap is read")
    parser.add_argument("--every", type=int, default=4, help="report every this many steps (and the last)")
    args = parser.parse_args()
    for path in args.results:
        res = SimulationResult.load(path)
        spec = ModelSpec.from_dict(res.spec)
        mesh = build_mesh(spec)
        points = contact_points(mesh, "surface", order=args.order)
        radius, height = spec.indenter.radius, spec.geometry.height
        print(
            f"{path}: mesh {spec.mesh.preset or spec.mesh.feb_file}, contact {res.spec.get('contact', 'stick')}"
        )
        print(
            "depth mm | force mN | nodes: smallest gap mm | face points: smallest gap mm | face area inside mm^2"
        )
        top0 = mesh.nodes[mesh.top]
        last = len(res.depth) - 1
        for k in range(1, last + 1):
            if k % args.every and k != last:
                continue
            x = top0 + res.displacement[k]
            on_faces = np.einsum("cqk,ckj->cqj", points.shape, x[points.cell_nodes]).reshape(-1, 3)
            centre = np.array([0.0, 0.0, height + radius - res.depth[k]])
            gap_faces = np.linalg.norm(on_faces - centre, axis=1) - radius
            gap_nodes = np.linalg.norm(x - centre, axis=1) - radius
            inside = float(points.area[gap_faces < -1e-3].sum())
            print(
                f"{res.depth[k]:.2f} | {res.force[k]:.1f} | {gap_nodes.min():+.3f} | "
                f"{gap_faces.min():+.3f} | {inside:.2f}"
            )


if __name__ == "__main__":
    main()
