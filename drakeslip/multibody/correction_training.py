"""Training the fitted template's learned correction (``drakeslip.apex_correction``) on the robot's hops.

The network learns the robot's next apex minus the template's (``fit.predict``) for each hop the robot flew as a
plan meant it (``verification/robot_hops.py``) from the hop and the hop before it (``hop_inputs``); full-batch Adam
on the squared error of the standardized outputs, the inputs standardized over the training hops and held inside
their range. ``train_correction`` returns the network's arrays with the errors the template plus it makes on held-out
hops.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from drakeslip.apex_correction import HELD_OUT_FIELDS, N_IN, N_OUT, correction_of, hop_inputs, output_units
from drakeslip.multibody.fit import Hop, predict, summary
from drakeslip.params import SlipParams


@dataclass(frozen=True)
class CorrectionConfig:
    """hidden units per layer, full-batch Adam epochs and learning rate, L2 weight decay, the share of the training
    hops shown once more without the hop before them (``unknown_before``: a plan's first hop is predicted so), the
    seed of the initial weights and of that choice, and the torch device ("auto": CUDA when there is one)."""

    hidden: int = 64
    epochs: int = 3000
    learning_rate: float = 3e-3
    weight_decay: float = 1e-4
    unknown_before: float = 0.3
    seed: int = 0
    device: str = "auto"


def residuals(hops: list[Hop], template: SlipParams) -> tuple[np.ndarray, np.ndarray]:
    """(the correction's inputs (n, N_IN), the robot's next apex minus the template's in output units (n, N_OUT):
    NaN rows where the template's hop fails) for ``hops``."""
    robot = np.array([h.next_apex for h in hops], dtype=np.float64).reshape(-1, N_OUT)
    units = output_units(template.leg_length, template.gravity)
    return hop_inputs(hops, template.leg_length, template.gravity), (robot - predict(hops, template)) / units


def corrected_errors(hops: list[Hop], template: SlipParams, arrays: dict) -> np.ndarray:
    """(n, 3) |robot - (template + the correction of network ``arrays``)| next apex for ``hops`` (x, z [m],
    xdot [m/s]); NaN where the template's hop fails."""
    inputs, target = residuals(hops, template)
    return np.abs(target - correction_of(arrays, inputs)) * output_units(template.leg_length, template.gravity)


def train_correction(train: list[Hop], held_out: list[Hop], template: SlipParams,
                     config: CorrectionConfig = CorrectionConfig()) -> dict:
    """The network arrays (``drakeslip.apex_correction.ARRAYS`` and "held_out") of a correction of ``template``
    trained on the hops ``train`` and tested on ``held_out`` (its "held_out" errors); ValueError when the template
    completes fewer than 10 of the training hops."""
    import torch

    from drakeslip.devices import torch_device

    inputs, target = residuals(train, template)
    ok = np.all(np.isfinite(target), axis=1)
    if ok.sum() < 10:
        raise ValueError(f"the template completes {int(ok.sum())} of the {len(train)} hops: too few to train on")
    inputs, target = inputs[ok], target[ok]
    rng = np.random.default_rng(config.seed)
    shown_again = (inputs[:, 6] > 0) & (rng.random(len(inputs)) < config.unknown_before)
    unknown = inputs[shown_again].copy()
    unknown[:, 3:6], unknown[:, 6] = unknown[:, 0:3], 0.0   # as hop_inputs writes a hop with no hop before it
    inputs, target = np.concatenate([inputs, unknown]), np.concatenate([target, target[shown_again]])
    mean, scale = inputs.mean(axis=0), np.maximum(inputs.std(axis=0), 1e-6)
    out_scale = np.maximum(target.std(axis=0), 1e-9)
    device = torch_device(config.device)
    torch.manual_seed(config.seed)
    net = torch.nn.Sequential(torch.nn.Linear(N_IN, config.hidden), torch.nn.Tanh(),
                              torch.nn.Linear(config.hidden, config.hidden), torch.nn.Tanh(),
                              torch.nn.Linear(config.hidden, N_OUT)).double().to(device)
    x = torch.as_tensor((inputs - mean) / scale, device=device)
    y = torch.as_tensor(target / out_scale, device=device)
    optimizer = torch.optim.Adam(net.parameters(), lr=config.learning_rate, weight_decay=config.weight_decay)
    for _ in range(config.epochs):
        optimizer.zero_grad()
        loss = torch.mean((net(x) - y) ** 2)
        loss.backward()
        optimizer.step()
    arrays = {}
    for k, layer in enumerate((m for m in net if isinstance(m, torch.nn.Linear)), 1):
        arrays[f"w{k}"] = layer.weight.detach().cpu().numpy().T.copy()
        arrays[f"b{k}"] = layer.bias.detach().cpu().numpy().copy()
    arrays.update(input_low=inputs.min(axis=0), input_high=inputs.max(axis=0), input_mean=mean, input_scale=scale,
                  output_scale=out_scale, held_out=np.full(len(HELD_OUT_FIELDS), np.nan))
    if held_out:
        stats = summary(corrected_errors(held_out, template, arrays))
        arrays["held_out"] = np.array([stats[name] for name in HELD_OUT_FIELDS])
    return arrays
