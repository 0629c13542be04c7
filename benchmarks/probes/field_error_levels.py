"""Benchmark (by hand): the high fidelity's field error between mesh levels, and what the adequacy
test makes of it as a covariance term (docs/validation/model-error.md, "That covariance term,
measured before it is built"; issue 57).

``shapes`` reads runs of one point at successive levels (``--run LEVEL:RUN.npz``, two or more) and
prints, root mean square over ``1.5 R`` to 25 mm and all steps, the in-plane difference of the top
field between successive levels, the ratio of the finest difference to the one before and their
cosine; with ``--other L3.npz:L4.npz`` (another point's pair) the cosine of the finest difference
between the two points.

``adequacy`` fits an experiment plain (``fit_experiment``, the shipped surrogate) and reads the
adequacy test as the fit does, then again with one more low-rank term of its covariance per pair
``--pair NAME:FINE_MINUS_ONE.npz:FINE.npz`` (the fine run's field less the coarser one's, moved
into the residual space at the fit): as one direction, and one per step and component.

    .venv/bin/python benchmarks/probes/field_error_levels.py shapes --radius 4.77 \\
        --run 1:L1.npz --run 2:L2.npz --run 3:L3.npz --run 4:L4.npz [--other L3b.npz:L4b.npz]
    .venv/bin/python benchmarks/probes/field_error_levels.py adequacy EXPERIMENT_DIR \\
        --pair other:L3b.npz:L4b.npz

``split`` parts the fine level less the coarse one on a 0.125 mm grid of the top (0 to 25 mm)
into what the coarse level's top nodes cannot carry (the fine field less its bilinear
interpolant from the coarse top nodes: the field inside the coarse elements) and what they carry
wrongly (the fine field at the coarse nodes less the coarse field, interpolated alike); root mean
square in plane and out of plane by distance from the axis at steps 10, 20 and 28.

    .venv/bin/python benchmarks/probes/field_error_levels.py split COARSE.npz FINE.npz

``variance`` fits an experiment plain and reads the adequacy test as the fit does (with the shipped
field error where one matches) and without any field error, then with the
high fidelity's field error as a variance at each node and step (``chi_square_test``'s
``field_variance``): the square of a pair's fine-less-coarse field, either at the node itself or
as the root mean square of its band of distance from the axis (0.25 R wide) and step, per
component: a pair of another point carries its bands over.

    .venv/bin/python benchmarks/probes/field_error_levels.py variance EXPERIMENT_DIR \
        --pair NAME:COARSE.npz:FINE.npz [--scale 1.0]

``records`` compares two lab records of one point made with one seed from runs at two levels
(``make_synthetic_experiment.py --from-run ... --lab``): their DIC data differ by the levels'
field at the DIC points alone. Root mean square and largest difference by distance from the point
of largest displacement at the last step, at the middle and the last step.

    .venv/bin/python benchmarks/probes/field_error_levels.py records FINE_DIR COARSE_DIR --radius 4.77
"""

from __future__ import annotations

import argparse
import itertools
import time

import numpy as np

from indentation_studio.forward.convergence.mesh_study import top_field_interpolator
from indentation_studio.forward.result import SimulationResult
from indentation_studio.inference.adequacy import of_fit
from indentation_studio.inference.adequacy.field_error import field_error_table, field_variance
from indentation_studio.inference.budgets.fit_moves import residual_changes
from indentation_studio.inference.fit.workflow import REGISTRATION_MM, fit_experiment


def _fields_on(run: SimulationResult, xy: np.ndarray) -> np.ndarray:
    """(steps, points, 3) the run's top field at ``xy`` (reference positions), steps 1..N."""
    return np.stack(
        [top_field_interpolator(run.top_xyz, run.displacement[k])(xy) for k in range(1, len(run.force))]
    )


def _cosine(a: np.ndarray, b: np.ndarray) -> float:
    a, b = a.ravel(), b.ravel()
    return float(a @ b / (np.linalg.norm(a) * np.linalg.norm(b)))


def _rms(a: np.ndarray) -> float:
    return float(np.sqrt(np.mean(a**2)))


def shapes(runs: dict[int, str], radius: float, other: str | None) -> None:
    """Print the successive levels' in-plane field differences (module docstring)."""
    levels = sorted(runs)
    loaded = {k: SimulationResult.load(runs[k]) for k in levels}
    xy = loaded[levels[-1]].top_xyz[:, :2]
    r = np.hypot(xy[:, 0], xy[:, 1])
    xy = xy[(r >= 1.5 * radius) & (r <= 25.0)]
    fields = {k: _fields_on(run, xy)[..., :2] for k, run in loaded.items()}
    diffs = {k: fields[k] - fields[j] for j, k in itertools.pairwise(levels)}
    for k, d in diffs.items():
        print(f"L{k} - L{k - 1}: rms ux {_rms(d[..., 0]):.4f} mm, uy {_rms(d[..., 1]):.4f} mm")
    if len(diffs) >= 2:
        last, before = diffs[levels[-1]], diffs[levels[-2]]
        ratio = np.linalg.norm(last) / np.linalg.norm(before)
        print(f"finest against the one before: ratio {ratio:.3f}, cosine {_cosine(last, before):.3f}")
    if other:
        coarse, fine = (SimulationResult.load(p) for p in other.split(":"))
        there = (_fields_on(fine, xy) - _fields_on(coarse, xy))[..., :2]
        here = diffs[levels[-1]]
        print(
            f"finest difference, this point against the other: cosine {_cosine(here, there):.3f} "
            f"(ux {_cosine(here[..., 0], there[..., 0]):.3f}, uy {_cosine(here[..., 1], there[..., 1]):.3f})"
        )


def _output_rows(coarse: SimulationResult, fine: SimulationResult, xy: np.ndarray) -> dict[str, np.ndarray]:
    """The fine run less the coarse one in the surrogate's output space (log force per step, then
    the field at ``xy``): as one row, and one row per step and component."""
    steps = len(coarse.force) - 1
    log_force = np.log(np.abs(fine.force[1:]) / np.abs(coarse.force[1:]))
    field = _fields_on(fine, xy) - _fields_on(coarse, xy)
    per = np.zeros((3 * steps, steps + field.size))
    for k in range(steps):
        for c in range(3):
            block = np.zeros_like(field)
            block[k, :, c] = field[k, :, c]
            per[3 * k + c, steps:] = block.ravel()
        per[3 * k + 2, k] = log_force[k]
    return {"one direction": np.concatenate([log_force, field.ravel()])[None], "per step and component": per}


def adequacy(experiment: str, pairs: list[str]) -> None:
    """Fit ``experiment`` plain and read its adequacy test with each pair's term added."""
    t = time.perf_counter()
    result = fit_experiment(experiment)
    print(f"fit {time.perf_counter() - t:.1f} s at {np.round(result.fit.theta, 3).tolist()}")
    shipped, _ = of_fit.fit_adequacy(result, registration_mm=REGISTRATION_MM)
    print(f"as the fit reads it: {shipped.ratio:.4f} per degree, p {shipped.p_value:.2e}")
    xy = np.asarray(result.inputs.objective.top_xyz)[:, :2]
    prediction = result.tested_fit.prediction
    own = of_fit._model_directions(result)
    original = of_fit._model_directions
    for pair in pairs:
        name, coarse_path, fine_path = pair.split(":")
        coarse, fine = SimulationResult.load(coarse_path), SimulationResult.load(fine_path)
        for kind, rows in _output_rows(coarse, fine, xy).items():
            moved = residual_changes(result.inputs.objective, result.inputs.eta, prediction, rows)
            directions = moved if own is None else np.vstack([own, moved])
            of_fit._model_directions = lambda _result, d=directions: d
            try:
                test, _ = of_fit.fit_adequacy(result, registration_mm=REGISTRATION_MM)
            finally:
                of_fit._model_directions = original
            print(
                f"  + {name} ({kind}): {test.ratio:.4f} per degree, p {test.p_value:.2e}, flagged {test.flagged}"
            )


def records(fine_dir: str, coarse_dir: str, radius: float) -> None:
    """Print where two lab records of one point differ (module docstring)."""
    fine, coarse = np.load(f"{fine_dir}/dic.npz"), np.load(f"{coarse_dir}/dic.npz")
    if not np.allclose(fine["xyz"], coarse["xyz"]):
        raise SystemExit("the two records do not share their DIC points: made with different seeds")
    xy, diff = fine["xyz"][:, :2], fine["u"] - coarse["u"]
    last = len(diff) - 1
    centre = xy[np.argmax(np.linalg.norm(coarse["u"][last], axis=1))]
    r = np.hypot(*(xy - centre).T)
    for lo, hi in ((0, radius), (radius, 1.5 * radius), (1.5 * radius, 10), (10, 15), (15, 25), (25, np.inf)):
        zone = (r >= lo) & (r < hi)
        if not zone.any():
            continue
        for step in (last // 2, last):
            d = diff[step, zone]
            print(
                f"r {lo:5.1f} to {hi:5.1f} mm ({zone.sum():4d} points), step {step + 1}: rms in plane "
                f"{np.sqrt(np.mean(np.sum(d[:, :2] ** 2, axis=1))):.4f} mm, out of plane "
                f"{_rms(d[:, 2]):.4f} mm, largest {np.abs(d).max():.4f} mm"
            )


def split(coarse_path: str, fine_path: str) -> None:
    """Print the fine less the coarse field parted into inside-element and nodal parts (docstring)."""
    coarse, fine = SimulationResult.load(coarse_path), SimulationResult.load(fine_path)
    grid = np.linspace(0.0, 25.0, 201)
    p = np.stack(np.meshgrid(grid, grid, indexing="ij"), axis=-1).reshape(-1, 2)
    r = np.hypot(p[:, 0], p[:, 1])
    nodes = coarse.top_xyz[:, :2]
    print(f"top nodes: coarse {len(coarse.top_xyz)}, fine {len(fine.top_xyz)}")
    for step in (10, 20, 28):
        at_fine = top_field_interpolator(fine.top_xyz, fine.displacement[step])
        f = at_fine(p)
        through_coarse_nodes = top_field_interpolator(coarse.top_xyz, at_fine(nodes))(p)
        c = top_field_interpolator(coarse.top_xyz, coarse.displacement[step])(p)
        parts = {
            "total": f - c,
            "inside elements": f - through_coarse_nodes,
            "at the nodes": through_coarse_nodes - c,
        }
        print(f"step {step} (in plane / out of plane, rms mm)")
        for lo, hi in ((0, 3), (3, 5), (5, 7), (7, 10), (10, 15), (15, 25)):
            z = (r >= lo) & (r < hi)
            cells = "  ".join(
                f"{name} {np.sqrt(np.mean(np.sum(d[z, :2] ** 2, axis=1))):.4f} / {_rms(d[z, 2]):.4f}"
                for name, d in parts.items()
            )
            print(f"  r {lo:4.1f} to {hi:4.1f} mm: {cells}")


def _at_nodes_variance(coarse: SimulationResult, fine: SimulationResult, nodes_xy, steps) -> np.ndarray:
    """(steps, nodes, 3) the fine-less-coarse field squared at the nodes themselves."""
    return np.stack(
        [
            (
                top_field_interpolator(fine.top_xyz, fine.displacement[k])(nodes_xy)
                - top_field_interpolator(coarse.top_xyz, coarse.displacement[k])(nodes_xy)
            )
            ** 2
            for k in steps
        ]
    )


def variance(experiment: str, pairs: list[str], scale: float) -> None:
    """Fit ``experiment`` plain and read its adequacy test with each pair's field variance."""
    t = time.perf_counter()
    result = fit_experiment(experiment)
    print(f"fit {time.perf_counter() - t:.1f} s at {np.round(result.fit.theta, 3).tolist()}")
    shipped, _ = of_fit.fit_adequacy(result, registration_mm=REGISTRATION_MM)
    print(
        f"as the fit reads it: {shipped.ratio:.4f} per degree, p {shipped.p_value:.2e} "
        f"(the shipped field error: {shipped.field_error})"
    )

    def test_with(field_variance: np.ndarray | None):
        """The fit's adequacy test, its other terms as the fit passes them, with this field variance."""
        return of_fit.model_adequacy(
            result.inputs,
            result.tested_fit,
            at_ends=of_fit.parameters_at_ends(result),
            registration_mm=REGISTRATION_MM,
            model_directions=of_fit._model_directions(result),
            field_variance=field_variance,
        )

    plain = test_with(None)
    print(f"without any field error: {plain.ratio:.4f} per degree, p {plain.p_value:.2e}")
    objective = result.inputs.objective
    nodes_xy = np.asarray(objective.top_xyz)[objective.measured][:, :2]
    steps = np.asarray(objective.steps, int) + 1
    depths = np.asarray(result.inputs.spec.protocol.depths, float)[steps - 1]
    radius = result.inputs.spec.indenter.radius
    for pair in pairs:
        name, coarse_path, fine_path = pair.split(":")
        coarse, fine = SimulationResult.load(coarse_path), SimulationResult.load(fine_path)
        own = _at_nodes_variance(coarse, fine, nodes_xy, steps)
        band = field_variance(field_error_table([(coarse, fine)], radius), nodes_xy, depths)  # the library's
        for kind, v in (("at each node", own), ("band rms", band)):
            test = test_with(scale**2 * v)
            print(
                f"  + {name} ({kind}, x{scale:g}): {test.ratio:.4f} per degree, p {test.p_value:.2e}, "
                f"flagged {test.flagged}; terms { ({k: round(d['statistic'], 1) for k, d in test.terms.items()}) }"
            )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="what", required=True)
    sh = sub.add_parser("shapes")
    sh.add_argument("--radius", type=float, required=True)
    sh.add_argument("--run", action="append", required=True, help="LEVEL:RUN.npz")
    sh.add_argument("--other", help="another point's COARSE.npz:FINE.npz")
    ad = sub.add_parser("adequacy")
    ad.add_argument("experiment")
    ad.add_argument("--pair", action="append", required=True, help="NAME:COARSE.npz:FINE.npz")
    sp = sub.add_parser("split")
    sp.add_argument("coarse")
    sp.add_argument("fine")
    va = sub.add_parser("variance")
    va.add_argument("experiment")
    va.add_argument("--pair", action="append", required=True, help="NAME:COARSE.npz:FINE.npz")
    va.add_argument("--scale", type=float, default=1.0)
    rec = sub.add_parser("records")
    rec.add_argument("fine")
    rec.add_argument("coarse")
    rec.add_argument("--radius", type=float, required=True)
    args = ap.parse_args()
    if args.what == "variance":
        variance(args.experiment, args.pair, args.scale)
    elif args.what == "split":
        split(args.coarse, args.fine)
    elif args.what == "records":
        records(args.fine, args.coarse, args.radius)
    elif args.what == "shapes":
        shapes({int(a.split(":")[0]): a.split(":", 1)[1] for a in args.run}, args.radius, args.other)
    else:
        adequacy(args.experiment, args.pair)


if __name__ == "__main__":
    main()
