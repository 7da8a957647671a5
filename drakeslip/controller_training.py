"""Training data and training loop for the StepLengthController.

Data (paper, section V-B, plus the terrain height): a grid over forward speed, apex height above the
ground under the body, ground height difference to the landing surface and leg angle, jittered inside each
grid cell, simulated with the fast step map. Each surviving touchdown gives one example
(xdot, z - h(x_L), x_L - x) -> theta where the inverse is single-valued. The touchdown only depends on the
height and the ground difference through their difference (the drop to the landing surface), so each grid
point is simulated on a flat terrain at the landing level, which is exact and needs no special terrain.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from drakeslip.controller import N_FEATURES, ControllerConfig, StepLengthController
from drakeslip.params import SlipParams
from drakeslip.stepmap import step_batch
from drakeslip.terrain import Terrain


def network(config: ControllerConfig):
    """The controller's network as a torch module for training: a plain tanh MLP, normalized features ->
    normalized leg angle. Its state dict is what StepLengthController reads."""
    import torch

    class MLP(torch.nn.Module):
        def __init__(self):
            super().__init__()
            sizes = [N_FEATURES] + [config.hidden] * config.layers
            self.hidden = torch.nn.ModuleList(torch.nn.Linear(a, b) for a, b in zip(sizes[:-1], sizes[1:]))
            self.head = torch.nn.Linear(config.hidden, 1)

        def forward(self, x):
            for layer in self.hidden:
                x = torch.tanh(layer(x))
            return self.head(x).squeeze(-1)

    return MLP()


@dataclass(frozen=True)
class DataConfig:
    speeds: tuple = (0.05, 4.5, 30)          # forward speed [m/s]: (min, max, points)
    heights: tuple = (0.45, 1.5, 16)         # apex height above the ground under the body [m]
    ground_deltas: tuple = (-0.5, 0.5, 9)    # landing surface minus ground under the body [m]
    angles: tuple = (-0.8, 0.8, 41)          # leg angle [rad]


@dataclass(frozen=True)
class TrainConfig:
    epochs: int = 200
    batch_size: int = 4096
    lr: float = 3e-3
    weight_decay: float = 0.0
    val_fraction: float = 0.05


def _axis(spec):
    """Cell starts and widths of a (min, max, points) grid axis."""
    lo, hi, n = spec
    edges = np.linspace(lo, hi, int(n) + 1)
    return edges[:-1], np.diff(edges)


def make_dataset(params: SlipParams, data: DataConfig = DataConfig(), seed: int = 0):
    """Simulate the jittered grid; returns (features (N, 3), angles (N,)) for every valid touchdown."""
    rng = np.random.default_rng(seed)
    grids = [_axis(spec) for spec in (data.speeds, data.heights, data.ground_deltas, data.angles)]
    mesh = np.stack(np.meshgrid(*[g[0] for g in grids], indexing="ij"), -1).reshape(-1, 4)
    width = np.array([g[1].mean() for g in grids])
    v, height, delta, theta = (mesh + rng.uniform(0, 1, mesh.shape) * width).T
    drop = height - delta
    # Flat ground at 0 is the landing surface; the body is `drop` above it (exact, see the module doc).
    keep = drop > 0.05
    v, drop, theta = v[keep], drop[keep], theta[keep]
    apex = np.stack([np.zeros_like(v), drop, v], axis=1)
    res = step_batch(apex, theta, Terrain.flat(0.0, x0=-5.0, length=20.0), params, parallel=True)
    # Every touchdown counts, not only hops that succeed on this flat ground: on uneven terrain the same
    # (speed, drop, offset) can start a successful hop (e.g. a high apex dropping onto a lower level).
    keep = np.isfinite(res.touchdown_x) & _invertible(v, drop, theta, params)
    feats = np.stack([v, drop, res.touchdown_x], axis=1)[keep]
    return feats, theta[keep]


def _invertible(v, drop, theta, params: SlipParams):
    """Where the touchdown grows with the leg angle, so the inverse map is single-valued: d x_L / d theta =
    L0 cos(theta) + v L0 sin(theta) / (g T) > 0 with T the fall time from apex to touchdown."""
    L0, g = params.leg_length, params.gravity
    fall = drop - L0 * np.cos(theta)
    T = np.sqrt(2 * np.maximum(fall, 1e-9) / g)
    return (fall > 1e-3) & (L0 * np.cos(theta) + v * L0 * np.sin(theta) / (g * T) > 0.1)


def train(feats: np.ndarray, theta: np.ndarray, params: SlipParams, config: ControllerConfig = ControllerConfig(),
          train_config: TrainConfig = TrainConfig(), seed: int = 0, log=print,
          device: str = "cpu") -> StepLengthController:
    """Fit the MLP with Adam and a cosine learning-rate schedule on the mean squared angle error, on torch
    ``device`` (drakeslip.devices.torch_device). The split and the batches are drawn on the CPU from ``seed``, so
    they are the same on every device."""
    import torch

    torch.set_num_threads(1)  # a 3-64-64-64-1 MLP gains nothing from more; OpenMP spinning on a busy machine costs 10x
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    order = rng.permutation(len(theta))
    n_val = max(1, int(len(theta) * train_config.val_fraction))
    val, tr = order[:n_val], order[n_val:]
    mean, std = feats[tr].mean(0), feats[tr].std(0)
    x = torch.tensor((feats - mean) / std, dtype=torch.float32, device=device)
    y = torch.tensor(theta / config.max_angle, dtype=torch.float32, device=device)
    model = network(config).to(device)
    opt = torch.optim.Adam(model.parameters(), lr=train_config.lr, weight_decay=train_config.weight_decay)
    steps_per_epoch = math.ceil(len(tr) / train_config.batch_size)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, T_max=train_config.epochs * steps_per_epoch)
    gen = torch.Generator().manual_seed(seed)
    tr_t, val_t = torch.tensor(tr), torch.tensor(val, device=device)
    t0 = time.perf_counter()
    for epoch in range(train_config.epochs):
        model.train()
        perm = tr_t[torch.randperm(len(tr_t), generator=gen)]
        for i in range(steps_per_epoch):
            idx = perm[i * train_config.batch_size:(i + 1) * train_config.batch_size].to(device)
            loss = torch.mean((model(x[idx]) - y[idx]) ** 2)
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            sched.step()
        if epoch % 25 == 0 or epoch == train_config.epochs - 1:
            model.eval()
            with torch.no_grad():
                val_rmse = torch.sqrt(torch.mean((model(x[val_t]) - y[val_t]) ** 2)).item() * config.max_angle
            log(f"epoch {epoch:4d}  train mse {loss.item():.3e}  val angle rmse {val_rmse:.2e} rad  "
                f"({time.perf_counter() - t0:.0f} s)", flush=True)
    return StepLengthController({k: v.detach().cpu().numpy() for k, v in model.state_dict().items()}, config, mean, std,
                                params)
