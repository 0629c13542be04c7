"""Embedded solver vs real FEBio 4 on FEBio's baseline mesh, both against converged meshes.

    python docs/figures/febio_agreement_table.py [--converged runs/mesh-study/10-350]

Solves the baseline (c1 = 10, c5 = 350 kPa, R = 4.77 mm, 28 x 0.5 mm) on the hex8 block of
../shared/febio/baseline/baseline.feb and prints, per depth, FEBio's force, ours, their
difference, and, when the mesh-study folder holds them, the forces of the ``fine`` and
``reference`` presets and both coarse solutions' deviation from the finest one; then the
top-surface displacement differences in the form of eq. 1b (ours vs FEBio, and each vs the
finest mesh, interpolated at FEBio's top nodes).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from indentation_studio.forward.convergence.mesh_study import interpolate_top_displacement
from indentation_studio.forward.result import SimulationResult
from indentation_studio.forward.solver import simulate
from indentation_studio.forward.spec import MeshChoice, ModelSpec

BASE = Path(__file__).resolve().parents[3] / "shared" / "febio" / "baseline"


def eq1b(u: np.ndarray, u_ref: np.ndarray) -> float:
    """Mean nodal relative displacement difference, percent (eq. 1b form)."""
    n = np.linalg.norm(u_ref, axis=1)
    keep = n > 1e-12
    return 100.0 * float(np.mean(np.linalg.norm(u - u_ref, axis=1)[keep] / n[keep]))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--converged", type=Path, default=Path("runs/mesh-study/10-350"))
    args = ap.parse_args()
    febio = np.load(BASE / "baseline.npz")
    ours = simulate(ModelSpec(mesh=MeshChoice(feb_file=str(BASE / "baseline.feb"))))
    finer = {
        name: SimulationResult.load(args.converged / f"{name}.npz")
        for name in ("fine", "reference")
        if (args.converged / f"{name}.npz").is_file()
    }
    best = finer.get("reference") or finer.get("fine")
    depth, F_fe, F_us = febio["depth"], febio["F_full"], ours.force
    head = f"{'depth':>6} {'FEBio':>10} {'ours':>10} {'ours/FEBio-1':>13}"
    for name in finer:
        head += f" {name:>10}"
    if best is not None:
        head += f" {'FEBio/best-1':>13} {'ours/best-1':>12}"
    print(f"wall time of ours on FEBio's mesh: {ours.wall_s:.2f} s")
    print(head)
    rows = (depth >= 1.0 - 1e-9) & (depth <= 14.0 + 1e-9)
    for k in range(1, len(depth)):
        line = f"{depth[k]:6.1f} {F_fe[k]:10.1f} {F_us[k]:10.1f} {100 * (F_us[k] / F_fe[k] - 1):+12.2f}%"
        for r in finer.values():
            line += f" {r.force[k]:10.1f}"
        if best is not None:
            line += f" {100 * (F_fe[k] / best.force[k] - 1):+12.2f}% {100 * (F_us[k] / best.force[k] - 1):+11.2f}%"
        print(line)
    diff = np.abs(F_us[rows] / F_fe[rows] - 1) * 100
    print(f"ours vs FEBio, 1 to 14 mm: mean |diff| {diff.mean():.2f}%, max {diff.max():.2f}%")
    if best is not None:
        for name, F in (("FEBio", F_fe), ("ours", F_us)):
            dev = np.abs(F[rows] / best.force[rows] - 1) * 100
            print(
                f"{name} vs {best.solver['mesh']['source']}: mean |diff| {dev.mean():.2f}%, max {dev.max():.2f}%"
            )
    u_fe = febio["U_top"][-1]
    print(f"E_u (eq. 1b form) ours vs FEBio at 14 mm: {eq1b(ours.displacement[-1], u_fe):.2f}%")
    for name, r in finer.items():
        u_ref = interpolate_top_displacement(r, febio["top_xyz0"][:, :2])
        print(
            f"E_u vs {name} at 14 mm: FEBio {eq1b(u_fe, u_ref):.2f}%, ours {eq1b(ours.displacement[-1], u_ref):.2f}%"
        )


if __name__ == "__main__":
    main()
