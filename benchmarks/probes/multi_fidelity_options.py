"""Multi-fidelity options on the same real data, run by hand (not part of the tests).

Low fidelity: the campaign ``p775c`` (775 points, `coarse` mesh) and the surrogates trained on it
(``runs/p775c/surrogate-{gp,mlp}.safetensors``, trained here when missing); high fidelity: the
campaign ``lhs200`` (200 LHS points, `default` mesh). The high level is trained on a space-filling
20 and 40 of the 200 (greedy maximin in log theta) and every option is tested on the rest:

* ``mf``: surrogate/multi_fidelity.py (GP of the discrepancy in PCA space) on the GP or MLP low
  surrogate; ``mf+rho``: the same with a least-squares scale factor rho on the low level (AR(1));
* ``smt-mfk``: SMT's MFK (recursive co-kriging) per standardised PCA score of the high training
  data, with the low campaign's responses (carried to the high nodes) projected on that basis;
* ``emukit``: emukit's linear multi-fidelity GP (GPy, Matern 5/2 per level) on the same scores;
* baselines: the high-only GP on the same points, and the low surrogates alone.

Training time excludes the low surrogates' own training (given apart); SMT and emukit train on
the 775 low points themselves. Errors over the test points and every step: force relative error
(max, mean, %), field error (RMS and max, mm).

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 \\
        python benchmarks/probes/multi_fidelity_options.py [--sizes 20 40] [--skip smt-mfk,emukit]
"""

from __future__ import annotations

import argparse
import contextlib
import io
import time
import warnings
from pathlib import Path

import numpy as np

from indentation_studio.atomic_write import atomic_write_json
from indentation_studio.campaign.loader import load_campaign
from indentation_studio.surrogate.base import InputScaler, TrainingData
from indentation_studio.surrogate.gaussian_process import GaussianProcessSurrogate
from indentation_studio.surrogate.multi_fidelity import MultiFidelitySurrogate, interpolation_matrix
from indentation_studio.surrogate.persistence import load_surrogate, save_surrogate
from indentation_studio.surrogate.scaling import pca_reduction
from indentation_studio.surrogate.training import make_surrogate, train_surrogate


def space_filling(theta: np.ndarray, m: int) -> np.ndarray:
    """m rows of theta, greedy maximin in log theta scaled to [0, 1], from the most central."""
    x = np.log(theta)
    x = (x - x.min(axis=0)) / (x.max(axis=0) - x.min(axis=0))
    chosen = [int(np.argmin(np.sum((x - 0.5) ** 2, axis=1)))]
    d = np.sum((x - x[chosen[0]]) ** 2, axis=1)
    while len(chosen) < m:
        chosen.append(int(np.argmax(d)))
        d = np.minimum(d, np.sum((x - x[chosen[-1]]) ** 2, axis=1))
    return np.array(chosen)


def carry(W, u: np.ndarray) -> np.ndarray:
    """A field (n, steps, low nodes, 3) at the high nodes."""
    n, s, _, c = u.shape
    return (W @ np.moveaxis(u, 2, 0).reshape(W.shape[1], -1)).reshape(-1, n, s, c).transpose(1, 2, 0, 3)


def low_surrogate(kind: str, runs: Path):
    path = runs / "p775c" / f"surrogate-{kind}.safetensors"
    if not path.is_file():
        save_surrogate(train_surrogate("p775c", kind, runs_dir=runs), path)
    return load_surrogate(path)


# ---------------------------------------------------------------- options: train -> predict(theta)
def fields(model):
    def predict(theta):
        p = model.predict(theta)
        return p.force, p.displacement

    return predict


def low_only(low, W):
    def train(data):
        def predict(theta):
            p = low.predict(theta)
            return p.force, carry(W, p.displacement)

        return predict

    return train


def high_only(data):
    return fields(make_surrogate("gp").fit(data))


def multi_fidelity(low):
    return lambda data: fields(MultiFidelitySurrogate(low, folds=0).fit(data))


def multi_fidelity_rho(low, W):
    """eq. 1 with log F = rho_f log F_lo + delta_f, u = rho_u W u_lo + delta_u; rho by least
    squares on the centred training responses (Kennedy-O'Hagan's AR(1) scale, estimated apart)."""

    def train(data):
        p = low.predict(data.theta)
        lf, ul = np.log(p.force), carry(W, p.displacement)

        def rho(a, b):
            a, b = a - a.mean(axis=0), b - b.mean(axis=0)
            return float(np.sum(a * b) / np.sum(a * a))

        rf, ru = rho(lf, np.log(data.force)), rho(ul, data.displacement)
        D = TrainingData(
            data.theta,
            np.exp(np.log(data.force) - rf * lf),
            data.displacement - ru * ul,
            data.depth,
            data.top_xyz,
        )
        delta = GaussianProcessSurrogate(per_component=True, max_components=8).fit(D)

        def predict(theta):
            lo, d = low.predict(theta), delta.predict(theta)
            return np.exp(rf * np.log(lo.force)) * d.force, ru * carry(W, lo.displacement) + d.displacement

        return predict

    return train


def score_space(data, low_data, W):
    """The high training data's PCA (force: log, field) and the standardised scores of the high
    training data and of the low campaign (carried to the high nodes) on that basis."""
    n_lo = low_data.n
    blocks = [
        (np.log(data.force), np.log(low_data.force), np.ones(data.force.shape[1])),
        (
            data.displacement.reshape(data.n, -1),
            carry(W, low_data.displacement).reshape(n_lo, -1),
            np.broadcast_to(
                np.abs(data.displacement).max(axis=(0, 1, 2)), data.displacement.shape[1:]
            ).reshape(-1),
        ),
    ]
    pcas = [pca_reduction(Y, scale, 1e-3, 8) for Y, _, scale in blocks]
    S_hi = np.hstack([p.transform(Y) for p, (Y, _, _) in zip(pcas, blocks, strict=True)])
    S_lo = np.hstack([p.transform(Y) for p, (_, Y, _) in zip(pcas, blocks, strict=True)])
    mean, std = S_hi.mean(axis=0), S_hi.std(axis=0)

    def outputs(T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        S = T * std + mean
        kf = pcas[0].n_components_
        force = np.exp(pcas[0].inverse_transform(S[:, :kf]))
        return force, pcas[1].inverse_transform(S[:, kf:]).reshape(len(T), *data.displacement.shape[1:])

    return (S_hi - mean) / std, (S_lo - mean) / std, outputs


def smt_mfk(low_data, W, scaler):
    from smt.applications.mfk import MFK

    def train(data):
        T_hi, T_lo, outputs = score_space(data, low_data, W)
        models = []
        for j in range(T_hi.shape[1]):
            sm = MFK(theta0=[1e-2, 1e-2], n_start=2, eval_noise=True, print_global=False)
            sm.set_training_values(scaler(low_data.theta), T_lo[:, j : j + 1], name=0)
            sm.set_training_values(scaler(data.theta), T_hi[:, j : j + 1])
            with contextlib.redirect_stdout(io.StringIO()):  # SMT prints failed Cholesky factors
                sm.train()
            models.append(sm)
        return lambda theta: outputs(np.hstack([m.predict_values(scaler(theta)) for m in models]))

    return train


def emukit_linear(low_data, W, scaler):
    import GPy
    from emukit.model_wrappers.gpy_model_wrappers import GPyMultiOutputWrapper
    from emukit.multi_fidelity.convert_lists_to_array import (
        convert_x_list_to_array,
        convert_xy_lists_to_arrays,
    )
    from emukit.multi_fidelity.kernels import LinearMultiFidelityKernel
    from emukit.multi_fidelity.models import GPyLinearMultiFidelityModel

    def train(data):
        T_hi, T_lo, outputs = score_space(data, low_data, W)
        models = []
        for j in range(T_hi.shape[1]):
            X, Y = convert_xy_lists_to_arrays(
                [scaler(low_data.theta), scaler(data.theta)], [T_lo[:, j : j + 1], T_hi[:, j : j + 1]]
            )
            kernel = LinearMultiFidelityKernel(
                [GPy.kern.Matern52(2, ARD=True), GPy.kern.Matern52(2, ARD=True)]
            )
            gpy_model = GPyLinearMultiFidelityModel(X, Y, kernel, n_fidelities=2)
            GPyMultiOutputWrapper(
                gpy_model, 2, n_optimization_restarts=1, verbose_optimization=False
            ).optimize()
            models.append(gpy_model)

        def predict(theta):
            X = convert_x_list_to_array([scaler(theta), scaler(theta)])[len(theta) :]  # high level
            meta = {"output_index": X[:, -1:].astype(int)}
            return outputs(np.hstack([m.predict(X, Y_metadata=meta)[0] for m in models]))

        return predict

    return train


# ---------------------------------------------------------------- measurement
def measure(train, data: TrainingData, test: TrainingData) -> dict:
    t0 = time.perf_counter()
    predict = train(data)
    train_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    force, disp = predict(test.theta)
    batch_ms = 1e3 * (time.perf_counter() - t0) / test.n
    t0 = time.perf_counter()
    for theta in test.theta[:10]:
        predict(theta[None])
    one_ms = 1e3 * (time.perf_counter() - t0) / 10
    rel = np.abs(force / test.force - 1.0)
    err = disp - test.displacement
    return {
        "force_max_pct": 100 * float(rel.max()),
        "force_mean_pct": 100 * float(rel.mean()),
        "field_rms_mm": float(np.sqrt(np.mean(err**2))),
        "field_max_mm": float(np.abs(err).max()),
        "train_s": train_s,
        "predict_ms_per_point": batch_ms,
        "predict_one_point_ms": one_ms,
    }


JACOBIANS = {
    "low-only": "yes (analytic/autograd)",
    "high-only GP": "yes (analytic)",
    "mf": "yes (analytic, tested)",
    "mf+rho": "possible (not wired)",
    "smt-mfk": "library (squar_exp only)",
    "emukit": "GPy gradients (not wired)",
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs-dir", type=Path, default=Path("runs"))
    parser.add_argument("--sizes", type=int, nargs="+", default=[20, 40])
    parser.add_argument("--skip", default="", help="comma-separated option names to leave out")
    args = parser.parse_args()
    warnings.filterwarnings("ignore")  # GP optimisers' convergence warnings
    skip = set(filter(None, args.skip.split(",")))
    low_data = TrainingData.from_campaign(load_campaign("p775c", args.runs_dir))
    high = TrainingData.from_campaign(load_campaign("lhs200", args.runs_dir))
    lows = {kind: low_surrogate(kind, args.runs_dir) for kind in ("gp", "mlp")}
    W = interpolation_matrix(low_data.top_xyz, high.top_xyz)
    scaler = InputScaler(low_data.theta.min(axis=0), low_data.theta.max(axis=0), "log")
    options = {
        "low-only GP": low_only(lows["gp"], W),
        "low-only MLP": low_only(lows["mlp"], W),
        "high-only GP": high_only,
        "mf (low GP)": multi_fidelity(lows["gp"]),
        "mf (low MLP)": multi_fidelity(lows["mlp"]),
        "mf+rho (low MLP)": multi_fidelity_rho(lows["mlp"], W),
        "smt-mfk": lambda data: smt_mfk(low_data, W, scaler)(data),
        "emukit": lambda data: emukit_linear(low_data, W, scaler)(data),
    }
    rows = []
    for m in args.sizes:
        rows_train = space_filling(high.theta, m)
        data, test = high.subset(rows_train), high.subset(np.setdiff1d(np.arange(high.n), rows_train))
        for name, train in options.items():
            if name.split(" ")[0] in skip or name in skip:
                continue
            row = {"high_points": m, "option": name, **measure(train, data, test)}
            row["jacobians"] = JACOBIANS[name.split(" (")[0] if not name.startswith("low") else "low-only"]
            rows.append(row)
            print(
                f"{m:3d} {name:18s} force max {row['force_max_pct']:6.2f} % mean {row['force_mean_pct']:5.2f} %  "
                f"field RMS {row['field_rms_mm']:.4f} max {row['field_max_mm']:.3f} mm  "
                f"train {row['train_s']:6.1f} s  predict {row['predict_ms_per_point']:.3f} ms/pt "
                f"(1 pt {row['predict_one_point_ms']:.2f} ms)  J: {row['jacobians']}",
                flush=True,
            )
    low_fit = {kind: model.meta.get("fit_s") for kind, model in lows.items()}
    print(f"low surrogates' own training (s, from their files): {low_fit}")
    out = atomic_write_json(
        args.runs_dir / "multi-fidelity-options.json", {"rows": rows, "low_fit_s": low_fit}
    )
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
