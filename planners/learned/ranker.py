"""A learned re-ranker of the mode planner's most probable first footholds.

The foothold that keeps a way on is often among the footstep model's few most probable first footholds without
being the first. Which of them leaves more room a hop later is a question of the hop's dynamics that a model
trained to imitate a planner does not resolve to the bin; the ranker answers it from what is known without
simulating:

- label (``training/labels.py``, used only to make training data): the room a hop later, the deepest run of
  working footholds on the 2.5 cm grid from the apex the candidate leads to (how far the next foothold may miss
  and still work);
- features (``candidate_features``): the apex relative to the candidate's ground, the candidate's distance and
  ground step, the controller's leg angle to it, its log-probability and rank under the footstep model, where in
  its cell it lies, and the terrain from 0.5 m behind it to 3 m ahead; lengths, speeds and cells in the hopper's
  units, as the footstep model reads them (planners/learned/inputs.py), so for the paper's hopper in metres;
- model: an MLP scoring each candidate; trained (training/train_ranker.py) with a listwise cross-entropy towards the
  candidates of most room, and evaluated here in numpy (per-call torch overhead would dominate a plan).
"""
from __future__ import annotations

import numpy as np
import torch
import torch.nn as nn

from drakeslip.jobs.files import atomic_write, first_line, load_weights, record_digest

from planners.base import Problem
from planners.learned.inputs import model_cell, relative_heights

FORMAT = "drakeslip-ranker/1"
ROOM_CAP = 12.0                 # grid steps; past the target there is nothing left to keep room for
SPACING = 0.025                 # the candidate grid (the sub-cell model's bins)
CELLS_BEHIND, CELLS_AHEAD = 5, 30
N_FEATURES = 8 + CELLS_BEHIND + CELLS_AHEAD


def candidate_features(problem: Problem, x: np.ndarray, log_p: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """(len(x), N_FEATURES) features of candidate first footholds ``x`` (most probable first), with their
    log-probabilities under the footstep model and the controller's leg angles to them, in the units of the
    problem's hopper (``Problem.units``)."""
    terrain, apex, units = problem.terrain, problem.apex, problem.units
    cell = model_cell(units)
    ground = terrain.height_at(x)
    body_ground = terrain.height_at(np.array([apex.x]))[0]
    around = x[:, None] + (np.arange(-CELLS_BEHIND, CELLS_AHEAD) + 0.5) * cell
    profile = relative_heights(terrain.height_at(around), terrain.height_at(around) <= terrain.ditch_height,
                               ground[:, None], units)
    in_cell = np.mod((x - terrain.x0) / cell, 1.0)
    return np.column_stack([(apex.z - ground) / units.length, np.full(x.size, apex.xdot / units.speed),
                            (x - apex.x) / units.length, np.clip((ground - body_ground) / units.length, -1.0, 1.0),
                            theta, log_p, np.arange(x.size), in_cell, profile]).astype(np.float32)


class RankerNet(nn.Module):
    """Scores a candidate: two hidden ReLU layers over its standardized features."""

    def __init__(self, hidden: int = 256):
        super().__init__()
        self.hidden = hidden
        self.mlp = nn.Sequential(nn.Linear(N_FEATURES, hidden), nn.ReLU(), nn.Linear(hidden, hidden), nn.ReLU(),
                                 nn.Linear(hidden, 1))

    def forward(self, features: torch.Tensor) -> torch.Tensor:
        return self.mlp(features).squeeze(-1)


def save_ranker(path, net: RankerNet, mean: np.ndarray, std: np.ndarray, extra: dict | None = None) -> None:
    """Write the ranker atomically: its network, and its feature normalisation as tensors (so it loads with
    ``weights_only``)."""
    payload = {"format": FORMAT, "hidden": net.hidden, "n_features": N_FEATURES, "state_dict": net.state_dict(),
               "mean": torch.tensor(np.asarray(mean, np.float32)), "std": torch.tensor(np.asarray(std, np.float32)),
               **(extra or {})}
    with atomic_write(path) as f:
        torch.save(payload, f)
    record_digest(path)


class FootholdRanker:
    """A trained ranker in numpy: ``scores(features)`` (higher: more room expected)."""

    def __init__(self, path):
        payload = load_weights(path, "ranker weights file")
        if not isinstance(payload, dict) or payload.get("format") != FORMAT:
            raise ValueError(f"{path} is not a drakeslip ranker checkpoint (missing format {FORMAT!r})")
        try:
            if payload["n_features"] != N_FEATURES:
                raise ValueError(f"it has {payload['n_features']} features, this code {N_FEATURES}")
            net = RankerNet(payload["hidden"])
            net.load_state_dict(payload["state_dict"])
            self.mean, self.std = (payload[k].double().numpy().reshape(N_FEATURES) for k in ("mean", "std"))
        except (KeyError, TypeError, AttributeError, RuntimeError, ValueError) as err:
            raise ValueError(f"ranker weights file {path} does not match the ranker: {first_line(err)}") from err
        self.layers = [(m.weight.detach().double().numpy().T, m.bias.detach().double().numpy())
                       for m in net.mlp if isinstance(m, nn.Linear)]

    def scores(self, features: np.ndarray) -> np.ndarray:
        h = (features - self.mean) / self.std
        for i, (w, b) in enumerate(self.layers):
            h = h @ w + b
            if i < len(self.layers) - 1:
                h = np.maximum(h, 0.0)
        return h[:, 0]


def top_candidates(score: np.ndarray, k: int) -> np.ndarray:
    """Indices of the ``k`` highest positive scores, most probable first."""
    top = np.argsort(-score, kind="stable")[:k]
    return top[score[top] > 0]


def log_probability(score: np.ndarray, top: np.ndarray) -> np.ndarray:
    return np.log(np.maximum(score[top], 1e-12))

