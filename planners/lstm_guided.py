"""LSTM-guided sampling (paper, section VI-A): the Step-space search with children sampled from the LSTM's
distribution over the next foothold, given the path from the root to the node being expanded."""
from __future__ import annotations

import numpy as np
import torch

from .angle_space import run_attempts
from .lstm_inputs import encode_window
from .lstm_planner import FootstepDistribution, load_model
from .registry import register
from .step_space import StepSpacePlanner


class PathConditionedSampler:
    """Next-foothold distributions for the nodes of one search tree. The LSTM state after each node's path is
    cached, so expanding a node costs one LSTM step (the paper passes the whole root-to-node path as the past
    steps; this is the same computation without repeating it)."""

    def __init__(self, net: FootstepDistribution, problem, temperature: float, seed: int):
        self.model = net.model
        self.enc = encode_window(problem.terrain, problem.apex)
        self.terrain, self.apex, self.s0, self.mask = net.tensors(self.enc)
        self.temperature = temperature
        self.rng = np.random.default_rng(seed)
        self.cache: dict = {}  # node -> (logits of the step after it, LSTM state after it)

    @torch.no_grad()
    def _advance(self, tree, node: int):
        if node not in self.cache:
            if node == 0:
                prev, state = self.s0, self.model.initial_state(self.apex)
            else:
                prev = torch.zeros(1, self.enc.terrain.size)
                prev[0, int(np.clip(self.enc.cell_of(tree.foothold[node]), 0, prev.shape[1] - 1))] = 1.0
                state = self._advance(tree, tree.parent[node])[1]
            logits, after = self.model(self.terrain, self.apex, prev.unsqueeze(1), state)
            self.cache[node] = (logits[0, -1], after)
        return self.cache[node]

    def sample(self, tree, node: int, k: int, candidates: np.ndarray) -> np.ndarray:
        """k distinct footholds drawn from ``candidates`` (the Step-space grid the hop can reach), each weighted by
        the temperature-scaled probability of its cell; returned sorted. Ditch cells have zero weight."""
        logits = self._advance(tree, node)[0] / self.temperature
        if self.mask is not None:
            logits = logits.masked_fill(self.mask[0], float("-inf"))
        cells = self.enc.cell_of(candidates)
        inside = (cells >= 0) & (cells < logits.shape[0])
        p = np.zeros(candidates.size)
        p[inside] = torch.softmax(logits, dim=-1).double().numpy()[cells[inside]]
        k = min(k, int(np.count_nonzero(p)))
        if k == 0:
            return np.zeros(0)
        return np.sort(self.rng.choice(candidates, size=k, replace=False, p=p / p.sum()))


@register("lstm-guided")
class LSTMGuidedPlanner(StepSpacePlanner):
    """Step-space search whose children are ``branching`` footholds sampled from the LSTM (temperature
    ``temperature`` widens the distribution for sampling); a search that finds nothing is retried with each
    ``fallback`` branching (the paper: 3, then 5). Every child still goes through the controller and the fast
    step map, so the plan is one the controller can hit."""

    def __init__(self, weights=None, branching: int = 3, fallback: tuple = (5,), temperature: float = 1.0,
                 mask_ditches: bool = True, seed: int = 0, **options):
        super().__init__(**options)
        for b in (branching, *fallback):
            if not (isinstance(b, int) and b >= 1):
                raise ValueError(f"branching factors must be positive integers, got {b!r}")
        if not temperature > 0:
            raise ValueError(f"temperature must be positive, got {temperature!r}")
        self.net = FootstepDistribution(load_model(weights), mask_ditches)
        self.attempts = (branching, *fallback)
        self.temperature = float(temperature)
        self.seed = seed

    def _plan(self, problem):
        self.controller.check_params(problem.params)
        return run_attempts(self, problem, [(f"B={b}", lambda b=b: self._search(problem, b)) for b in self.attempts])

    def _search(self, problem, branching):
        sampler = PathConditionedSampler(self.net, problem, self.temperature, self.seed)

        def propose(tree, node):
            grid = self.candidates(tree.apex[node], problem.terrain, problem.params, self.spacings[0],
                                   problem.window_end)
            return sampler.sample(tree, node, branching, grid)

        return self.search_with(problem, propose)
