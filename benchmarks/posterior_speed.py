"""Benchmark (by hand): the posterior's cost on a surrogate, with F evaluated from the rebuilt fields
("before": ``reduced=False``, Objective.value on predict()'s steps x nodes x 3 fields) and in the
surrogate's PCA space ("after": design/reduced_objective.py), on one core.

    .venv/bin/python benchmarks/posterior_speed.py --campaign lhs200 [--kinds gp,mlp]
        [--walkers 32] [--steps 5000] [--before-steps 5000]

For each surrogate kind (trained on the campaign and saved beside it, or loaded from there when
present): a synthetic experiment made with the FE solver at (11, 260) kPa on the campaign's model
(2 % noise, processed as a measured one: node masks and Appendix B weights of a real test), the
LM fit on the surrogate for the start and sigma (as `indent-studio posterior` does), then the same
seeded emcee run on both paths: wall and CPU time, the samples' largest difference, medians and
95 % intervals; and the cost of one 16-walker evaluation of each piece. ``--paper-size-stand-in``
adds a GP of the paper's 775 training points whose responses come from the campaign's GP (for
its cost only, when the 775-point campaign cannot be afforded). Results go to
runs/<campaign>/posterior-speed.json (``--out``). BLAS, OpenMP and torch are held to one thread.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
import torch  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

from indentation_studio.atomic_write import atomic_write_json  # noqa: E402
from indentation_studio.campaign.designs import design_from_option  # noqa: E402
from indentation_studio.campaign.loader import load_campaign  # noqa: E402
from indentation_studio.design.reduced_objective import FieldObjective, ReducedObjective  # noqa: E402
from indentation_studio.forward.fe_predictor import FESolverPredictor  # noqa: E402
from indentation_studio.forward.spec import ModelSpec  # noqa: E402
from indentation_studio.inference.experiment.data import load_experiment  # noqa: E402
from indentation_studio.inference.experiment.processing import experiment_objective  # noqa: E402
from indentation_studio.inference.experiment.synthetic import write_synthetic_experiment  # noqa: E402
from indentation_studio.inference.fit.inverse_fit import fit_parameters  # noqa: E402
from indentation_studio.inference.posterior.sampling import sample_posterior  # noqa: E402
from indentation_studio.surrogate.base import TrainingData  # noqa: E402
from indentation_studio.surrogate.persistence import load_surrogate, save_surrogate  # noqa: E402
from indentation_studio.surrogate.training import make_surrogate  # noqa: E402

TRUTH = np.array([11.0, 260.0])
ETA = (0.45, 0.35, 0.2, 0.0)


def surrogate_of(kind: str, campaign: str, runs_dir: Path, pca_tol: float = 1e-3):
    suffix = "" if pca_tol == 1e-3 else f"-pca{pca_tol:g}"
    path = runs_dir / campaign / f"surrogate-{kind}{suffix}.safetensors"
    if path.is_file():
        return load_surrogate(path), str(path), 0.0
    t0 = time.perf_counter()
    data = TrainingData.from_campaign(load_campaign(campaign, runs_dir))
    model = make_surrogate(kind, pca_tol=pca_tol).fit(data)
    return model, str(save_surrogate(model, path)), time.perf_counter() - t0


def per_call_ms(f, repeats: int = 300) -> float:
    f()
    t0 = time.perf_counter()
    for _ in range(repeats):
        f()
    return 1e3 * (time.perf_counter() - t0) / repeats


def timed_posterior(objective, model, sigma: float, start, walkers: int, steps: int, reduced: bool):
    c0, t0 = time.process_time(), time.perf_counter()
    box = (model.scaler.lo, model.scaler.hi)
    post = sample_posterior(
        objective,
        model,
        ETA,
        s=sigma,
        box=box,
        start=start,
        walkers=walkers,
        steps=steps,
        seed=1,
        reduced=reduced,
    )
    return post, time.perf_counter() - t0, time.process_time() - c0


def paper_size_stand_in(model, runs_dir: Path, campaign: str):
    """A GP of the paper's size when its 775-point campaign is more than the machine can afford:
    the paper grid mapped onto ``model``'s training box, responses predicted by ``model`` (fields
    of the real kind, so a like number of PCA components), a GP trained on them (no optimizer
    restarts, to save time). Only its cost means anything: the GP's kernel work grows with the
    training points, the rest of F does not."""
    path = runs_dir / campaign / "surrogate-gp-paper-size-stand-in.safetensors"
    if path.is_file():
        return load_surrogate(path), str(path), 0.0
    grid = design_from_option("paper").points
    lo, hi = model.scaler.lo, model.scaler.hi
    theta = lo + (grid - grid.min(axis=0)) / (grid.max(axis=0) - grid.min(axis=0)) * (hi - lo)
    pred = model.predict(theta)
    data = TrainingData(theta, pred.force, pred.displacement, model.depth, model.top_xyz, model.parameters)
    t0 = time.perf_counter()
    stand_in = make_surrogate("gp", restarts=0).fit(data)
    return stand_in, str(save_surrogate(stand_in, path)), time.perf_counter() - t0


def benchmark_model(model, model_file: str, fit_s: float, args, experiment, before_steps: int) -> dict:
    """One surrogate: the fit, the cost of each piece, both posterior runs."""
    objective, _ = experiment_objective(experiment, model.top_xyz)
    fit = fit_parameters(objective, model, ETA)
    sigma = float(np.sqrt(fit.F / (fit.n_residuals - len(fit.theta))))
    rng = np.random.default_rng(0)
    batch = fit.theta * (1.0 + 0.01 * rng.standard_normal((args.walkers // 2, 2)))
    reduced = ReducedObjective(objective, model.reduced_basis(), ETA)
    full = FieldObjective(objective, model, ETA)
    scores = model._score_function()
    X = model.scaler(batch)
    pieces = {
        "predict_fields_ms": per_call_ms(lambda: model.predict(batch)),
        "full_F_ms": per_call_ms(lambda: full.value(batch)),
        "reduced_F_ms": per_call_ms(lambda: reduced.value(batch)),
        "regressor_ms": per_call_ms(lambda: scores(X)),
        "reduced_setup_ms": per_call_ms(lambda: ReducedObjective(objective, model.reduced_basis(), ETA), 20),
    }
    F_full, F_red = full.value(batch), reduced.value(batch)
    after, after_wall, after_cpu = timed_posterior(
        objective, model, sigma, fit.theta, args.walkers, args.steps, True
    )
    before, before_wall, before_cpu = timed_posterior(
        objective, model, sigma, fit.theta, args.walkers, before_steps, False
    )
    entry = {
        "model_file": model_file,
        "training_points": int(model.meta["training_points"]),
        "train_s": fit_s,
        "force_components": int(model.k_force),
        "field_components": int(model.field_pca.n_components_),
        "measured_nodes": int(objective.measured.sum()),
        "field_residuals": reduced.field_residuals,
        "fit_theta": fit.theta.tolist(),
        "sigma": sigma,
        "per_call_16_walkers": pieces,
        "max_rel_F_difference": float(np.max(np.abs(F_red / F_full - 1.0))),
        "before": {"wall_s": before_wall, "cpu_s": before_cpu, **_summary(before)},
        "after": {"wall_s": after_wall, "cpu_s": after_cpu, **_summary(after)},
        "speedup_wall": (before_wall / before_steps) / (after_wall / args.steps),
        "speedup_cpu": (before_cpu / before_steps) / (after_cpu / args.steps),
    }
    if before_steps == args.steps:
        entry["max_sample_difference"] = float(np.max(np.abs(before.samples - after.samples)))
    return entry


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--campaign", default="lhs200")
    ap.add_argument("--runs-dir", type=Path, default=Path("runs"))
    ap.add_argument("--kinds", default="gp,mlp")
    ap.add_argument("--walkers", type=int, default=32)
    ap.add_argument("--steps", type=int, default=5000)
    ap.add_argument("--before-steps", type=int, default=None, help="steps of the slow path (default --steps)")
    ap.add_argument("--pca-tol", type=float, default=1e-3, help="PCA tolerance of the surrogates trained")
    ap.add_argument("--out", default="posterior-speed.json", help="report file in the campaign's folder")
    ap.add_argument(
        "--paper-size-stand-in",
        action="store_true",
        help="also time a GP trained on 775 paper-grid points predicted by the campaign's GP",
    )
    args = ap.parse_args()
    torch.set_num_threads(1)
    before_steps = args.before_steps or args.steps
    data = load_campaign(args.campaign, args.runs_dir)
    spec = ModelSpec.from_dict(data.spec["model"])
    folder = args.runs_dir / args.campaign / "posterior-speed-experiment"
    if not (folder / "experiment.json").is_file():
        write_synthetic_experiment(
            FESolverPredictor(spec), TRUTH, folder, spec.indenter.radius, spec.protocol.step_size, seed=7
        )
    experiment = load_experiment(folder)
    report = {
        "campaign": args.campaign,
        "training_points": len(data.theta),
        "steps": int(data.force.shape[1]),
        "top_nodes": len(data.top_xyz),
        "walkers": args.walkers,
        "after_steps": args.steps,
        "before_steps": before_steps,
        "truth": TRUTH.tolist(),
        "kinds": {},
    }
    for kind in args.kinds.split(","):
        with threadpool_limits(1):
            model, model_file, fit_s = surrogate_of(kind, args.campaign, args.runs_dir, args.pca_tol)
            runs = {kind: (model, model_file, fit_s)}
            if kind == "gp" and args.paper_size_stand_in:
                runs["gp-775-stand-in"] = paper_size_stand_in(model, args.runs_dir, args.campaign)
            for name, (m, f, s) in runs.items():
                entry = benchmark_model(m, f, s, args, experiment, before_steps)
                report["kinds"][name] = entry
                print(json.dumps({name: entry}, indent=1), flush=True)
    report["pca_tol"] = args.pca_tol
    out = atomic_write_json(args.runs_dir / args.campaign / args.out, report)
    print(f"written {out}")


def _summary(post) -> dict:
    s = post.summary()
    return {k: s[k] for k in ("median", "ci95", "acceptance_fraction", "autocorrelation_steps", "samples")}


if __name__ == "__main__":
    main()
