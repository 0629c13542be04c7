"""Agreement with FEBio 4 on FEBio's own mesh: the force-depth curves and the top-surface
displacement profiles at 14 mm along the fibers (y) and across them (x), FEBio's baseline run
against the embedded solver with the node-wise stick (the default) and with the surface contact
(2 x 2 points per face).

    .venv/bin/python docs/figures/febio_agreement.py

Reads FEBio's run (../shared/febio/baseline/baseline.npz, .feb), solves the same model twice on
that mesh (a few seconds) and writes docs/validation/figures/febio-agreement.png.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from indentation_studio.forward import Contact, MeshChoice, ModelSpec, simulate

ROOT = Path(__file__).resolve().parents[2]
BASE = ROOT.parent / "shared" / "febio" / "baseline"
OUT = ROOT / "docs" / "validation" / "figures" / "febio-agreement.png"


def profile(xyz: np.ndarray, u: np.ndarray, axis: int) -> tuple[np.ndarray, np.ndarray]:
    """The nodes on the other axis's symmetry line (coordinate 0), sorted along ``axis``."""
    on_line = np.abs(xyz[:, 1 - axis]) < 1e-6
    order = np.argsort(xyz[on_line, axis])
    return xyz[on_line, axis][order], u[on_line][order]


def agreement_figure(febio, ours: dict) -> plt.Figure:
    """FEBio's run (its ``baseline.npz`` arrays) against our results on its mesh: the force against
    depth, the difference in percent from 1 mm on, and the top-surface profiles at the last step
    across and along the fibers."""
    depth, force = febio["depth"], febio["F_full"]
    fig, axes = plt.subplots(1, 4, figsize=(15, 3.8), constrained_layout=True)
    ax = axes[0]
    ax.plot(depth, force, "k-", lw=2.5, label="FEBio 4")
    for i, (name, r) in enumerate(ours.items()):
        ax.plot(r.depth, r.force, "--", color=f"C{i}", label=name)
    ax.set(xlabel="depth (mm)", ylabel="force (mN)", title="force against depth")
    ax.legend(fontsize=8)
    ax = axes[1]
    shown = depth >= 1.0 - 1e-9
    for i, (name, r) in enumerate(ours.items()):
        ax.plot(
            depth[shown], 100 * (r.force[shown] / force[shown] - 1), "o-", ms=3, color=f"C{i}", label=name
        )
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set(xlabel="depth (mm)", ylabel="ours / FEBio - 1 (%)", title="force difference, 1 to 14 mm")
    ax.legend(fontsize=8)
    xyz_fe, u_fe = febio["top_xyz0"], febio["U_top"][-1]
    for ax, axis, label in ((axes[2], 0, "x (across the fibers)"), (axes[3], 1, "y (along the fibers)")):
        s, u = profile(xyz_fe, u_fe, axis)
        ax.plot(s, u[:, 2], "k-", lw=2.5, label="FEBio 4, u_z")
        ax.plot(s, u[:, axis], "k:", lw=2.5, label=f"FEBio 4, u_{'xy'[axis]}")
        for i, (name, r) in enumerate(ours.items()):
            s, u = profile(r.top_xyz, r.displacement[-1], axis)
            ax.plot(s, u[:, 2], "--", color=f"C{i}", label=f"{name}, u_z")
            ax.plot(s, u[:, axis], ":", color=f"C{i}")
        ax.set_xlim(0.0, 25.0)
        ax.set(
            xlabel=f"{label} (mm)", ylabel="displacement at 14 mm (mm)", title=f"top surface along {label}"
        )
        ax.legend(fontsize=7)
    fig.suptitle(
        "FEBio's baseline (c1 = 10, c5 = 350 kPa, R = 4.77 mm, 28 x 0.5 mm) on its own mesh", fontsize=10
    )
    return fig


def main() -> None:
    febio = np.load(BASE / "baseline.npz")
    mesh = MeshChoice(feb_file=str(BASE / "baseline.feb"))
    ours = {
        "ours, node-wise stick": simulate(ModelSpec(mesh=mesh)),
        "ours, surface 2 x 2": simulate(
            ModelSpec(mesh=mesh, contact=Contact(integration="surface", order=2))
        ),
    }
    fig = agreement_figure(febio, ours)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(OUT, dpi=110)
    shown = febio["depth"] >= 1.0 - 1e-9
    for name, r in ours.items():
        diff = np.abs(r.force[shown] / febio["F_full"][shown] - 1) * 100
        print(f"{name}: mean |diff| {diff.mean():.2f} %, max {diff.max():.2f} %")
    print(OUT)


if __name__ == "__main__":
    main()
