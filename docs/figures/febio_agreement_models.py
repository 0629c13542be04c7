"""The force at every step of the studio's models beside real FEBio 4 on the shared baseline.

    .venv/bin/python docs/figures/febio_agreement_models.py --out docs/validation/data/febio-agreement-models.json \
        --figure docs/validation/figures/febio-agreement-models.png

The baseline (c1 = 10, c5 = 350 kPa, R = 4.77 mm, 28 x 0.5 mm): ``default`` (FEBio's mesh node for
node) with the node-wise stick, with the surface stick at 2 x 2 and 1 x 1 points a face, and the
levels of the family that follows the contact (``contact-L0`` .. ``contact-L3``, their own surface
stick at 1 x 1). A run that stops early keeps the steps it finished (its failure is recorded).
Prints each model's force at every 2 mm and its difference from FEBio's in percent, and writes
the whole table with each run's wall time and Newton iterations.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from indentation_studio import __version__
from indentation_studio.forward.solver import EmbeddedSolver, SimulationError
from indentation_studio.forward.spec import Contact, MeshChoice, ModelSpec

BASE = Path(__file__).resolve().parents[3] / "shared" / "febio" / "baseline"

MODELS = {
    "default, node-wise stick": ModelSpec(),
    "default, surface stick 2x2": ModelSpec(contact=Contact(integration="surface", order=2)),
    "default, surface stick 1x1": ModelSpec(contact=Contact(integration="surface", order=1)),
    **{f"contact-L{k}, surface stick 1x1": ModelSpec(mesh=MeshChoice(f"contact-L{k}")) for k in range(4)},
}


def run(spec: ModelSpec) -> dict:
    """One model at the baseline: force per step, wall time, Newton iterations, failure if any."""
    t0 = time.perf_counter()
    try:
        result = EmbeddedSolver(spec).run()
        depth, force, failure, newton = result.depth, result.force, None, int(result.newton_iterations)
    except SimulationError as exc:
        partial = getattr(exc, "partial", None)
        depth = np.asarray(getattr(partial, "depth", [0.0]))
        force = np.asarray(getattr(partial, "force", [0.0]))
        failure, newton = str(exc), None
    return {
        "depth_mm": np.asarray(depth).tolist(),
        "force_mN": np.asarray(force).tolist(),
        "wall_s": time.perf_counter() - t0,
        "newton_iterations": newton,
        "failure": failure,
        "spec": spec.to_dict(),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--figure", type=Path)
    ap.add_argument("--only", nargs="*", help="model names to run (default all)")
    args = ap.parse_args()
    febio = np.load(BASE / "baseline.npz")
    f_febio = np.asarray(febio["F_full"], float)
    runs = json.loads(args.out.read_text())["models"] if args.out.is_file() else {}
    for name, spec in MODELS.items():
        if (args.only and name not in args.only) or name in runs:
            continue
        print(f"{name} ...", flush=True)
        runs[name] = run(replace(spec))
        payload = {
            "febio": {"depth_mm": np.asarray(febio["depth"]).tolist(), "force_mN": f_febio.tolist()},
            "models": runs,
            "code_version": __version__,
            "command": "docs/figures/febio_agreement_models.py",
        }
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(payload, indent=1))
    print(f"{'model':34s} {'wall s':>7s} {'Newton':>6s} " + " ".join(f"{d:>7g}mm" for d in range(2, 15, 2)))
    for name, r in runs.items():
        f = np.asarray(r["force_mN"])
        cells = []
        for d in range(2, 15, 2):
            k = 2 * d
            cells.append(f"{100 * (f[k] / f_febio[k] - 1):+8.2f}%" if k < len(f) else f"{'failed':>9s}")
        print(f"{name:34s} {r['wall_s']:7.1f} {r['newton_iterations'] or '-':>6} " + " ".join(cells))
        if r["failure"]:
            print(f"    {r['failure'][:160]}")
    if args.figure:
        fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
        d_f = np.asarray(febio["depth"])
        a.plot(d_f, f_febio, "k-", lw=2.5, label="FEBio 4 (shared baseline)")
        for name, r in runs.items():
            d, f = np.asarray(r["depth_mm"]), np.asarray(r["force_mN"])
            a.plot(d, f, label=name)
            n = min(len(f), len(f_febio))
            b.plot(d[1:n], 100 * (f[1:n] / f_febio[1:n] - 1), label=name)
        a.set_xlabel("depth, mm")
        a.set_ylabel("force, mN (whole specimen)")
        b.set_xlabel("depth, mm")
        b.set_ylabel("force against FEBio's, %")
        b.axhline(0, color="k", lw=0.8)
        for ax in (a, b):
            ax.grid(alpha=0.3)
        b.legend(fontsize=7)
        fig.suptitle("c1 = 10, c5 = 350 kPa, R = 4.77 mm: the studio's models against FEBio 4", fontsize=10)
        fig.tight_layout()
        args.figure.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(args.figure, dpi=130)
        print(f"wrote {args.figure}")


if __name__ == "__main__":
    main()
