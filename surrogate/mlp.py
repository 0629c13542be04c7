"""MLP emulator (torch, CPU): scaled parameters -> standardised PCA scores of log-force and field.

Trained full-batch with Adam, then refined with L-BFGS, keeping the weights with the lowest
error on a held-out validation split (early stopping); seeds fixed so a training is repeatable.
Jacobians by autograd (torch.func.jacrev, vectorised over points).

Evaluating the ensemble at a small batch (a sampler's walkers, many thousand times) costs torch's
per-operation dispatch more than arithmetic, and torch's intra-op threads make it erratic on a busy
machine (README, "Experiments"): :class:`EnsembleForward` holds the networks' weights as stacked
float64 numpy arrays and runs all members at once, a few array operations per layer."""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from .base import FieldSurrogate


def _network(p: int, k: int, width: int, hidden_layers: int) -> nn.Sequential:
    layers: list[nn.Module] = []
    n_in = p
    for _ in range(hidden_layers):
        layers += [nn.Linear(n_in, width), nn.Tanh()]
        n_in = width
    layers.append(nn.Linear(n_in, k))
    return nn.Sequential(*layers).double()


class EnsembleForward:
    """The mean of an ensemble of ``_network`` MLPs (Linear, Tanh, ..., Linear) as numpy: X (n, p)
    -> (n, k), float64, the same numbers as the torch networks up to rounding."""

    def __init__(self, nets: list[nn.Sequential]) -> None:
        linears = [[m for m in net if isinstance(m, nn.Linear)] for net in nets]
        for net, layers in zip(nets, linears, strict=True):
            kinds = [type(m) for m in net]
            expected = [t for _ in layers[:-1] for t in (nn.Linear, nn.Tanh)] + [nn.Linear]
            if kinds != expected:
                raise ValueError(f"EnsembleForward needs Linear/Tanh layers ending in Linear, got {net}")
        with torch.no_grad():
            # y = x W^T + b in torch; stacked over members: (members, in, out), (members, 1, out)
            self.weights = [
                np.stack([m[i].weight.double().numpy().T for m in linears]) for i in range(len(linears[0]))
            ]
            self.biases = [
                np.stack([m[i].bias.double().numpy()[None, :] for m in linears])
                for i in range(len(linears[0]))
            ]

    def __call__(self, X: np.ndarray) -> np.ndarray:
        h = np.asarray(X, np.float64)[None]  # (1, n, p), broadcast over the members
        last = len(self.weights) - 1
        for i, (W, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            h = h @ W + b
            if i < last:
                h = np.tanh(h)
        return h.mean(axis=0)


class MLPSurrogate(FieldSurrogate):
    """A surrogate whose PCA scores are learned by an ensemble of torch MLPs (tanh).

    Each member is trained by Adam then L-BFGS on its own seed and validation split; the
    prediction is the ensemble's mean.

    Parameters
    ----------
    width : int, default 64
        Units per hidden layer.
    hidden_layers : int, default 3
        Hidden layers.
    adam_epochs : int, default 3000
        Adam epochs at most.
    lbfgs_steps : int, default 300
        L-BFGS steps after Adam.
    validation_fraction : float, default 0.15
        Fraction of the points held out for early stopping (none below 10 points).
    patience : int, default 400
        Epochs without a better validation loss before Adam stops.
    ensemble : int, default 3
        Networks in the ensemble.
    **kwargs
        ``input_scale``, ``pca_tol``, ``max_components`` of :class:`FieldSurrogate`.
    """

    kind = "mlp"

    def __init__(
        self,
        width: int = 64,
        hidden_layers: int = 3,
        adam_epochs: int = 3000,
        lbfgs_steps: int = 300,
        validation_fraction: float = 0.15,
        patience: int = 400,
        ensemble: int = 3,
        **kwargs,
    ) -> None:
        super().__init__(**kwargs)
        self.width, self.hidden_layers = width, hidden_layers
        self.adam_epochs, self.lbfgs_steps = adam_epochs, lbfgs_steps
        self.validation_fraction, self.patience = validation_fraction, patience
        self.ensemble = ensemble

    def hyperparameters(self) -> dict:
        """The constructor's arguments: :meth:`FieldSurrogate.hyperparameters` with the MLP's."""
        return {
            **super().hyperparameters(),
            "width": self.width,
            "hidden_layers": self.hidden_layers,
            "adam_epochs": self.adam_epochs,
            "lbfgs_steps": self.lbfgs_steps,
            "validation_fraction": self.validation_fraction,
            "patience": self.patience,
            "ensemble": self.ensemble,
        }

    def _regressor_state(self):
        """Each network's weights (float64 arrays ``mlp<i>.<layer>.weight|bias``) and its shape."""
        arrays = {
            f"mlp{i}.{key}": tensor.detach().numpy()
            for i, net in enumerate(self.nets)
            for key, tensor in net.state_dict().items()
        }
        shape = {"inputs": self.nets[0][0].in_features, "outputs": self.nets[0][-1].out_features}
        return {"networks": len(self.nets), **shape}, arrays

    def _restore_regressor(self, config, arrays) -> None:
        """Networks of the saved shape built on the meta device (no random initialisation, the
        global torch generator is left alone) and given the saved weights."""
        self.nets = []
        for i in range(config["networks"]):
            with torch.device("meta"):
                net = _network(config["inputs"], config["outputs"], self.width, self.hidden_layers)
            state = {}
            for key in net.state_dict():
                name = f"mlp{i}.{key}"
                if name not in arrays:
                    raise KeyError(f"array {name!r} missing")
                state[key] = torch.from_numpy(np.require(arrays[name], np.float64, ["C", "W"]))
            net.load_state_dict(state, strict=True, assign=True)
            self.nets.append(net.eval())

    def _fit_regressor(self, X: np.ndarray, T: np.ndarray, seed: int) -> None:
        """``ensemble`` networks from different seeds and validation splits; their mean is the
        prediction (averaging removes most of one network's wiggles, which derivatives, hence
        Hessians and bounds, feel first)."""
        if int(self.ensemble) != self.ensemble or self.ensemble < 1:
            raise ValueError(f"ensemble must be a positive whole number, got {self.ensemble!r}")
        threads = torch.get_num_threads()
        torch.set_num_threads(1)  # full-batch steps on a few hundred rows: threads only add waiting,
        try:  # and on a loaded machine their spinning multiplies the training time
            members = [self._train_one(X, T, seed + 1000 * k) for k in range(int(self.ensemble))]
        finally:
            torch.set_num_threads(threads)
        self.nets = [net for net, _ in members]
        self.meta["validation_mse"] = [v for _, v in members]
        self.meta["architecture"] = f"{self.ensemble} x ({self.hidden_layers} x {self.width} tanh)"

    def _train_one(self, X: np.ndarray, T: np.ndarray, seed: int) -> tuple[nn.Sequential, float]:
        torch.manual_seed(seed)
        rng = np.random.default_rng(seed)
        n = len(X)
        order = rng.permutation(n)
        n_val = round(self.validation_fraction * n) if n >= 10 else 0
        val, train = order[:n_val], order[n_val:]
        Xt, Tt = torch.from_numpy(X[train]), torch.from_numpy(T[train])
        Xv, Tv = torch.from_numpy(X[val]), torch.from_numpy(T[val])
        net = _network(X.shape[1], T.shape[1], self.width, self.hidden_layers)
        # the loss is the squared error of log-force and of the field in output units (each block
        # normalised to weight 1): a standardised minor component must not count as much as the first
        var = self.score_std**2
        w = np.concatenate(
            [var[: self.k_force] / var[: self.k_force].sum(), var[self.k_force :] / var[self.k_force :].sum()]
        )
        weight = torch.from_numpy(w * len(w) / w.sum())

        def loss_fn(pred: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
            return torch.mean((pred - target) ** 2 * weight)

        def val_loss() -> float:
            with torch.no_grad():
                return float(loss_fn(net(Xv), Tv)) if n_val else float(loss_fn(net(Xt), Tt))

        best = (np.inf, None)

        def keep() -> None:
            nonlocal best
            v = val_loss()
            if v < best[0]:
                best = (v, {k: t.clone() for k, t in net.state_dict().items()})

        opt = torch.optim.Adam(net.parameters(), lr=3e-3)
        sched = torch.optim.lr_scheduler.ReduceLROnPlateau(opt, factor=0.5, patience=150)
        since = 0
        for _ in range(self.adam_epochs):
            opt.zero_grad()
            loss = loss_fn(net(Xt), Tt)
            loss.backward()
            opt.step()
            sched.step(loss.item())
            previous = best[0]
            keep()
            since = 0 if best[0] < previous else since + 1
            if since > self.patience:
                break
        net.load_state_dict(best[1])
        lbfgs = torch.optim.LBFGS(net.parameters(), lr=1.0, max_iter=20, line_search_fn="strong_wolfe")

        def closure():
            lbfgs.zero_grad()
            loss = loss_fn(net(Xt), Tt)
            loss.backward()
            return loss

        for _ in range(max(self.lbfgs_steps // 20, 1)):
            lbfgs.step(closure)
            keep()
        net.load_state_dict(best[1])
        return net.eval(), best[0]

    def _score_function(self):
        return EnsembleForward(self.nets)

    def _regress(self, X: np.ndarray, jacobian: bool):
        x = torch.from_numpy(np.ascontiguousarray(X, dtype=np.float64))
        with torch.no_grad():
            T = np.mean([net(x).numpy() for net in self.nets], axis=0)
        if not jacobian:
            return T, None
        jac = np.mean(
            [torch.func.vmap(torch.func.jacrev(net))(x).detach().numpy() for net in self.nets], axis=0
        )
        return T, jac  # (n, k, p)
