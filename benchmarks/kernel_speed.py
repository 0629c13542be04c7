"""The element kernel alone, against another commit's (by hand, before landing a kernel change).

The three-field hex8 kernel (``forward.hex8_kernel_numba``) on FEBio's baseline mesh (1,100
elements) at a random state, with its tangent and without, timed as the best of ``--repeats``
calls (the best, not the median: on a shared machine the best is the kernel's own cost), against
the kernel of ``--against`` (a git revision, compiled from ``git show REV:forward/hex8_kernel_numba.py``
in a temporary module) in the same process; both must agree to round-off.

    .venv/bin/python benchmarks/kernel_speed.py --against HEAD~1 [--threads 1] [--repeats 40]
"""

from __future__ import annotations

import argparse
import functools
import importlib.util
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from numba import set_num_threads

from indentation_studio.forward import hex8_mean_dilatation as element
from indentation_studio.forward.hex8_kernel_numba import hex8_three_field_kernel
from indentation_studio.forward.mesh import build_mesh
from indentation_studio.forward.spec import MeshChoice, ModelSpec

ROOT = Path(__file__).resolve().parents[1]
FEB = ROOT.parent / "shared" / "febio" / "baseline" / "baseline.feb"


def kernel_at(revision: str, folder: Path):
    """The kernel function of ``revision``, compiled from its source (without numba's disk cache)."""
    source = subprocess.run(
        ["git", "show", f"{revision}:forward/hex8_kernel_numba.py"],
        cwd=ROOT,
        check=True,
        capture_output=True,
        text=True,
    ).stdout.replace("cache=True", "cache=False")
    path = folder / "kernel_at_revision.py"
    path.write_text(source)
    spec = importlib.util.spec_from_file_location("kernel_at_revision", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    kernel = module.hex8_three_field_kernel
    if kernel.py_func.__code__.co_argcount == 16:  # before the kernel marked the taut fibers (issue 58)
        return lambda *args: kernel(*args[:16])
    return kernel


def state_with(kernel, geo, ue, fiber, **options):
    """The elements' state (tangent and parameter derivatives) computed by ``kernel``."""
    element.hex8_three_field_kernel = kernel
    return element.element_state(geo, ue, 10.0, 350.0, 1000.0, fiber, parameter_derivatives=True, **options)


def best_ms(kernel, call, repeats: int) -> float:
    """The best of ``repeats`` calls of ``call`` with ``kernel`` in place, ms."""
    element.hex8_three_field_kernel = kernel
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        call()
        times.append(time.perf_counter() - t0)
    return 1e3 * min(times)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--against", default="HEAD", help="the git revision to compare with")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--repeats", type=int, default=40)
    args = ap.parse_args()
    set_num_threads(args.threads)
    mesh = build_mesh(ModelSpec(mesh=MeshChoice(feb_file=str(FEB))))
    geo = element.ReferenceGeometry.of(mesh)
    ue = (0.05 * np.random.default_rng(0).standard_normal(mesh.nodes.shape))[mesh.elements]
    fiber = np.array([0.0, 1.0, 0.0])
    with tempfile.TemporaryDirectory() as folder:
        other = kernel_at(args.against, Path(folder))
        for options in ({}, {"fiber_mean": True}):
            a, b = (state_with(k, geo, ue, fiber, **options) for k in (other, hex8_three_field_kernel))
            worst = max(
                abs(a.stiffness - b.stiffness).max() / abs(a.stiffness).max(),
                abs(a.force - b.force).max() / abs(a.force).max(),
            )
            print(f"{options or 'Gauss-point fibers'}: largest relative difference {worst:.1e}")
            if worst > 1e-12:
                print("the kernels disagree", file=sys.stderr)
                return 1
        for tangent in (True, False):
            call = functools.partial(
                element.element_state, geo, ue, 10.0, 350.0, 1000.0, fiber, tangent=tangent
            )
            before = best_ms(other, call, args.repeats)
            after = best_ms(hex8_three_field_kernel, call, args.repeats)
            what = "with the tangent" if tangent else "forces only"
            print(
                f"{what}: {args.against} {before:.2f} ms, working tree {after:.2f} ms "
                f"({100 * (after / before - 1):+.0f} %; best of {args.repeats}, {args.threads} thread(s), "
                f"{len(mesh.elements)} elements)"
            )
    element.hex8_three_field_kernel = hex8_three_field_kernel
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
