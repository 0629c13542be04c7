"""Benchmark (by hand, not in the test suite): does a finer mesh's discrepancy depend on friction?

A multi-fidelity surrogate over (c1, c5, mu) either learns its discrepancy (what a finer mesh
changes, eq. 1 of ``surrogate/multi_fidelity.py``) at the perfect stick and applies it at every mu,
or needs a high-fidelity campaign with a mu axis. This measures which, on the FE models themselves
(no surrogate error in it): at each point {c1, c5} and each mu (and the stick), the low mesh and the
high mesh are solved, and the discrepancy D(mu) = [log F_hi - log F_lo, u_hi - W u_lo] (W the
interpolation from the low to the high top nodes) is compared with D(stick). The error of using
D(stick) at mu is D(mu) - D(stick), printed in the surrogates' validation metric (force relative
rms over the steps; field rms over nodes and steps relative to max |u| of each direction of the
high mesh's response); beside it the size of D(mu) itself (what the correction carries).

Runs are kept in ``--out`` (``<mesh>/c1-<c1>_c5-<c5>_mu-<mu>.npz``) and reused, so the script
resumes; each run is on one thread.

    .venv/bin/python benchmarks/probes/discrepancy_by_mu.py --out runs/discrepancy-mu \\
        --points 10:350,3:540,19:120 --mus 0.2,0.5,1,3 --high fine
    .venv/bin/python benchmarks/probes/discrepancy_by_mu.py --out runs/discrepancy-mu \\
        --high family:8x8:1.2:1.5:core8:2:surface1
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from indentation_studio.forward.result import SimulationResult
from indentation_studio.forward.solver import EmbeddedSolver, SimulationError
from indentation_studio.forward.spec import Contact, Indenter, Material, MeshChoice, ModelSpec
from indentation_studio.studio.verification_cli import parse_family
from indentation_studio.surrogate.multi_fidelity import interpolation_matrix


def model(name: str) -> tuple[MeshChoice, object, Contact]:
    """A mesh and contact from ``preset`` or ``family:FAMILY:LEVEL:CONTACT`` (CONTACT node or surfaceN)."""
    if not name.startswith("family:"):
        return MeshChoice(name), None, Contact()
    _, rest = name.split(":", 1)
    family, level, contact = rest.rsplit(":", 2)
    mesh = parse_family(family).mesh(int(level))
    if contact == "node":
        return MeshChoice("default"), mesh, Contact()
    return MeshChoice("default"), mesh, Contact(integration="surface", order=int(contact[len("surface") :]))


def run(
    name: str, c1: float, c5: float, mu: float | None, radius: float, out: Path
) -> SimulationResult | None:
    """The response of model ``name`` at (c1, c5, mu), from ``out`` if it was solved before."""
    tag = "stick" if mu is None else f"{mu:g}"
    path = out / name.replace(":", "_") / f"R{radius:g}_c1-{c1:g}_c5-{c5:g}_mu-{tag}.npz"
    if path.exists():
        return SimulationResult.load(path)
    choice, mesh, contact = model(name)
    spec = ModelSpec(
        indenter=Indenter(radius),
        material=Material(c1=c1, c5=c5),
        mesh=choice,
        contact=Contact(friction=mu, integration=contact.integration, order=contact.order),
    )
    t0 = time.perf_counter()
    try:
        result = EmbeddedSolver(spec, mesh).run(threads=1)
    except SimulationError as exc:
        print(f"  {name} {c1:g},{c5:g} mu {tag}: failed ({exc})", flush=True)
        return None
    path.parent.mkdir(parents=True, exist_ok=True)
    result.save(path)
    print(f"  {name} {c1:g},{c5:g} mu {tag}: {time.perf_counter() - t0:.1f} s", flush=True)
    return result


def discrepancy(low: SimulationResult, high: SimulationResult) -> tuple[np.ndarray, np.ndarray]:
    """D = (log F_hi - log F_lo per step, u_hi - W u_lo at the high top nodes); steps where either
    force is not positive (a coarse mesh that touches no node yet) are left out of the force."""
    W = interpolation_matrix(low.top_xyz, high.top_xyz)
    carried = np.einsum("ij,sjk->sik", W.toarray(), low.displacement)
    touching = (high.force > 0) & (low.force > 0)
    return np.log(high.force[touching] / low.force[touching]), high.displacement - carried


def metric(df: np.ndarray, du: np.ndarray, high: SimulationResult) -> dict[str, float]:
    """Force rms % and field rms % of max |u| per direction (the surrogates' validation metric)."""
    u_max = np.maximum(np.abs(high.displacement).max(axis=(0, 1)), 1e-12)
    rel_u = du / u_max
    return {
        "force_rms_pct": 100 * float(np.sqrt(np.mean(np.expm1(df) ** 2))),
        "field_rms_pct": 100 * float(np.sqrt(np.mean(rel_u**2))),
        **{f"u{'xyz'[j]}_rms_pct": 100 * float(np.sqrt(np.mean(rel_u[..., j] ** 2))) for j in range(3)},
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--points", default="10:350,3:540,19:120", help="c1:c5,... kPa")
    ap.add_argument("--mus", default="0.2,0.5,1,3")
    ap.add_argument("--radius", type=float, default=4.77)
    ap.add_argument("--low", default="default", help="a preset or family:FAMILY:LEVEL:CONTACT")
    ap.add_argument("--high", default="fine", help="a preset or family:FAMILY:LEVEL:CONTACT")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    points = [tuple(float(v) for v in p.split(":")) for p in args.points.split(",")]
    mus: list[float | None] = [None] + [float(m) for m in args.mus.split(",")]
    rows = []
    for c1, c5 in points:
        responses = {}
        for mu in mus:
            lo = run(args.low, c1, c5, mu, args.radius, args.out)
            hi = run(args.high, c1, c5, mu, args.radius, args.out)
            if lo is not None and hi is not None:
                responses[mu] = (lo, hi)
        if None not in responses:
            continue
        stick = discrepancy(*responses[None])
        for mu, (lo, hi) in responses.items():
            d = discrepancy(lo, hi)
            rows.append(
                {
                    "c1": c1,
                    "c5": c5,
                    "mu": mu,
                    "discrepancy": metric(*d, hi),
                    "stick_discrepancy_error": metric(d[0] - stick[0], d[1] - stick[1], hi),
                }
            )
            if not args.json:
                r = rows[-1]
                size, err = r["discrepancy"], r["stick_discrepancy_error"]
                print(
                    f"{c1:5g} {c5:6g} mu {'stick' if mu is None else f'{mu:g}':>5}: D force {size['force_rms_pct']:.3f} %"
                    f" field {size['field_rms_pct']:.3f} % | D - D(stick): force {err['force_rms_pct']:.3f} %"
                    f" field {err['field_rms_pct']:.3f} % (ux {err['ux_rms_pct']:.3f}, uy {err['uy_rms_pct']:.3f},"
                    f" uz {err['uz_rms_pct']:.3f})",
                    flush=True,
                )
    if args.json:
        print(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
