"""Benchmark (by hand, not in the test suite): the surface-integrated contact against Hertz and
against real FEBio 4, beside the node-wise stick.

* Hertz: a neo-Hookean half-space (c1 = 10 kPa, c5 = 0; incompressible, so stick and frictionless
  agree), R = 4.77 mm, two steps of 0.25 mm on ``default`` and ``fine``: F / (16/3 mu sqrt(R) d^1.5).
* FEBio: the paper protocol on FEBio's baseline mesh (../shared/febio/baseline), the force on the
  steps FEBio balanced, 1 to 14 mm, relative to FEBio's.

    .venv/bin/python benchmarks/probes/surface_contact_checks.py
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np

from indentation_studio.forward.solver import EmbeddedSolver
from indentation_studio.forward.spec import Contact, Material, MeshChoice, ModelSpec, Protocol

FEBIO = Path(__file__).resolve().parents[3] / "shared" / "febio" / "baseline"
CONTACTS = (Contact(), Contact(integration="surface", order=2), Contact(integration="surface", order=3))


def hertz() -> None:
    for mesh in ("default", "fine"):
        spec = ModelSpec(
            material=Material(c1=10.0, c5=0.0),
            protocol=Protocol(step_size=0.25, steps=2),
            mesh=MeshChoice(mesh),
        )
        for contact in CONTACTS:
            t = time.perf_counter()
            r = EmbeddedSolver(dataclasses.replace(spec, contact=contact)).run()
            ratio = r.force[1:] / (16.0 / 3.0 * 20.0 * np.sqrt(4.77) * r.depth[1:] ** 1.5)
            print(
                f"Hertz, {mesh}, {contact.describe()}: F / F_Hertz at 0.25, 0.5 mm = "
                f"{ratio[0]:.4f}, {ratio[1]:.4f} ({time.perf_counter() - t:.1f} s)",
                flush=True,
            )


def febio() -> None:
    ref = np.load(FEBIO / "baseline.npz")
    for contact in CONTACTS:
        spec = ModelSpec(mesh=MeshChoice(feb_file=str(FEBIO / "baseline.feb")), contact=contact)
        t = time.perf_counter()
        r = EmbeddedSolver(spec).run()
        band = (r.depth >= 1.0) & (r.depth <= 14.0) & (ref["imbalance"] < 1e-3)
        rel = 100.0 * (r.force[band] / ref["F_full"][band] - 1.0)
        print(
            f"FEBio baseline, {contact.describe()}: force vs FEBio mean |rel| {np.mean(np.abs(rel)):.2f} %, "
            f"from {rel.min():+.2f} to {rel.max():+.2f} % ({time.perf_counter() - t:.1f} s)",
            flush=True,
        )


if __name__ == "__main__":
    hertz()
    febio()
