"""The learned recurrent planner (paper, section VI): footholds from the CNN+LSTM model, zero ODE calls."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from drakeslip import ApexState, Terrain
from drakeslip.controller import StepLengthController

from .base import FootstepSequence, Plan, Planner, Problem
from .lstm_inputs import WindowEncoding, encode_window
from .lstm_model import FootstepModel, load_checkpoint
from .registry import register

DEFAULT_WEIGHTS = Path(__file__).with_name("weights") / "lstm.pt"
_MODELS: dict = {}


def load_model(path=None) -> FootstepModel:
    """The footstep model from ``path`` (default: the committed planners/weights/lstm.pt), loaded once."""
    path = str(path or DEFAULT_WEIGHTS)
    if path not in _MODELS:
        _MODELS[path] = load_checkpoint(path)[0]
    return _MODELS[path]


class FootstepDistribution:
    """Runs the model on one perception window. ``mask_ditches`` forbids ditch cells (a foot there is a
    certain FOOT_COLLISION, a physical constraint rather than a terrain heuristic)."""

    def __init__(self, model: FootstepModel, mask_ditches: bool = True):
        self.model = model
        self.mask_ditches = mask_ditches

    def tensors(self, enc: WindowEncoding):
        terrain = torch.from_numpy(enc.terrain)[None]
        apex = torch.from_numpy(enc.apex)[None]
        s0 = torch.zeros(1, enc.terrain.size)
        s0[0, enc.s0] = 1.0
        mask = torch.from_numpy(enc.ditch)[None] if self.mask_ditches else None
        return terrain, apex, s0, mask

    def rollout(self, enc: WindowEncoding, n_steps: int, temperature: float = 1.0) -> np.ndarray:
        terrain, apex, s0, mask = self.tensors(enc)
        return self.model.rollout(terrain, apex, s0, n_steps, mask, temperature)[0].numpy()


@register("lstm")
class LSTMPlanner(Planner):
    """Footholds = the mode (argmax) of each step's distribution, fed back as the next step's input, until a
    foothold passes the target (at most ``max_steps``). The controller executes them; the plan holds the
    first leg angle (from the current apex) and leaves later angles and apexes as NaN, since the model does
    not predict them."""

    def __init__(self, weights=None, max_steps: int = 12, mask_ditches: bool = True,
                 controller: StepLengthController | None = None, **budget):
        super().__init__(**budget)
        if not (isinstance(max_steps, int) and max_steps >= 1):
            raise ValueError(f"max_steps must be a positive integer, got {max_steps!r}")
        self.model = load_model(weights)
        self.net = FootstepDistribution(self.model, mask_ditches)
        self.max_steps = max_steps
        self.controller = controller or StepLengthController.load_default()

    def distributions(self, apex, terrain: Terrain, n: int, temperature: float = 1.0):
        """Per-step probabilities over the window's cells, (n, cells), and the cells' centres x (cells,)."""
        apex = ApexState(*map(float, apex)).validate()
        enc = encode_window(terrain, apex)
        return self.net.rollout(enc, n, temperature), enc.x_of(np.arange(enc.terrain.size))

    def _plan(self, problem: Problem) -> Plan:
        enc = encode_window(problem.terrain, problem.apex)
        probs = self.net.rollout(enc, self.max_steps)
        footholds = enc.x_of(probs.argmax(axis=1))
        passed = np.flatnonzero(footholds >= problem.target_x)
        footholds = footholds[:passed[0] + 1] if passed.size else footholds
        footholds = footholds[footholds < problem.window_end]
        if footholds.size == 0 or footholds[0] <= problem.apex.x - problem.params.leg_length:
            return Plan(self.name, False, problem.target_x, message="no plan found: the model's first step "
                        "is not ahead of the hopper")
        angles = np.full(footholds.size, np.nan)
        angles[0] = self.controller.leg_angle(problem.apex, footholds[0], problem.terrain)
        seq = FootstepSequence(footholds, angles, np.full((footholds.size, 3), np.nan))
        return Plan(self.name, True, problem.target_x, sequences=[seq])
