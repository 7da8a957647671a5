"""LSTM-guided sampling (paper, section VI-A): the Step-space search with children sampled from the LSTM's
distribution over the next foothold, given the path from the root to the node being expanded."""
from __future__ import annotations

import functools
import time

import numpy as np

from drakeslip import ApexState, Terrain
from drakeslip.compiled import compiling
from drakeslip.terrain import DITCH_HEIGHT

from planners.base import Plan
from planners.checkpoints import SPATIAL_WEIGHTS, SUBCELL_WEIGHTS
from planners.core.grid import children_of
from planners.core.sampled import SampledExpansion, WindowSettings, weighted_order
from planners.learned.inference import softmax
from planners.learned.inputs import SAME_CELL, encode_window, model_cell
from planners.learned.lstm import FootstepDistribution, load_model
from planners.learned.spatial_guided import plan_on_map
from planners.search.robust import Robustness
from planners.search.step_space import StepSpacePlanner, attempt_name
from planners.search.loop import search
from planners.search.tree import CostWeights

# Node budget of each search attempt: a node costs several times a Step-space node (an LSTM step besides the
# controller and the step map), so this bounds a call that finds no plan to a few seconds as Step-space's does.
MAX_NODES = 500
# On a height map: the spatial model's cells a node flies, the first time the search expands it and each time it comes
# back (4 cells are 4 candidates at their centres, 16 at 5 cm, 64 at 2.5 cm; the label's cell is among the model's 4
# first in 91 % of the held-out samples and among its 8 first in 96 %, docs/reproduction.md)
MAP_CELLS = (4, 8)
_COMPILED: list = []  # holds True once this process has compiled (or loaded) the sampled core


class PathConditionedSampler:
    """Next-foothold distributions for the nodes of one search tree. The LSTM state after each node's path is
    cached, so expanding a node costs one LSTM step (the paper passes the whole root-to-node path as the past
    steps; this is the same computation without repeating it).

    ``conditioning="apex"`` instead starts the model afresh at every node, from the apex the
    search simulated there: the first step of a sequence is the one the model predicts best, because it is
    the only one whose apex it is told; later steps depend on apexes it can only infer from the path."""

    def __init__(self, net: FootstepDistribution, problem, temperature: float, conditioning: str = "path"):
        self.net, self.model = net, net.model
        self.problem = problem
        self.enc = encode_window(problem.terrain, problem.apex, problem.units)
        self.terrain, self.apex, self.s0, self.mask = net.inputs(self.enc)
        self.temperature = temperature
        self.conditioning = conditioning
        self.cache: dict = {}  # node -> (probabilities of the step after it, LSTM state after it or its window)

    def _restart(self, tree, node: int):
        """The model's first-step distribution from the node's own apex and window."""
        enc = encode_window(self.problem.terrain, ApexState(*tree.apex[node]), self.problem.units)
        terrain, apex, s0, mask = self.net.inputs(enc)
        logits, _ = self.model.step(terrain, s0, self.model.initial_state(apex))
        return softmax(logits[0] / self.temperature, None if mask is None else mask[0]), enc

    def _advance(self, tree, node: int):
        if node not in self.cache and self.conditioning == "apex":
            self.cache[node] = self._restart(tree, node)
        if node not in self.cache:
            if node == 0:
                prev, state = self.s0, self.model.initial_state(self.apex)
            else:
                prev = np.zeros_like(self.s0)
                prev[0, int(np.clip(self.net.bin_of(self.enc, tree.foothold[node]), 0, prev.shape[1] - 1))] = 1.0
                state = self._advance(tree, tree.parent[node])[1]
            logits, after = self.model.step(self.terrain, prev, state)
            self.cache[node] = (softmax(logits[0] / self.temperature, None if self.mask is None else self.mask[0]),
                                after)
        return self.cache[node]

    def probabilities(self, tree, node: int, x_l: np.ndarray) -> np.ndarray:
        """The temperature-scaled probability of each candidate foothold's bin for the step after ``node``
        (0 outside the window and, with ditch masking, in ditches)."""
        probs, after = self._advance(tree, node)
        bins = self.net.bin_of(after if self.conditioning == "apex" else self.enc, x_l)
        inside = (bins >= 0) & (bins < probs.size)
        p = np.zeros(x_l.size)
        p[inside] = probs[bins[inside]]
        return p


class LSTMGuidedPlanner(StepSpacePlanner):
    """Step-space search whose children are ``branching`` footholds sampled from the LSTM (temperature
    ``temperature`` widens the distribution for sampling); a search that finds nothing is retried with each
    ``fallback`` branching (the paper: 3, then 5). Every child still goes through the controller and the fast
    step map, so the plan is one the controller can hit. ``model`` is the LSTM checkpoint; ``cost_weights`` the
    node cost's, as Step-space's.

    Progressive widening: a node whose sampled children all fail draws the next ``branching`` instead of dying,
    and a node with candidates left returns to the queue, so the search comes back to it when its children's
    subtrees die. Often only a band of footholds a few cm wide keeps the hop and the next one alive, narrower
    than the model's 10 cm cells, so three samples may miss it while the fourth or seventh hits it. Only the
    drawn candidates are aimed (the controller's cost dominates a Step-space expansion). ``floor`` gives every
    candidate at least that weight, so that from a state the model has not learned (a noisy robot's) the search
    can still reach any foothold, the model's least likely last; 0 samples only what the model deems possible.
    ``grid_fallback``: when the sampled searches find nothing, search Step-space's whole grid before giving up.
    Then, as Step-space's, the pruned stage (``pruned_nodes``; ``planners.search.pruned``).

    The defaults are the best shipped setting: the sub-cell model (2.5 cm bins, ``SUBCELL_WEIGHTS``), restarted
    from each node's own apex (``conditioning="apex"``), its samples simulated one at a time in their drawn order
    (``lazy``). The paper's search, all B samples at once with the model fed the root-to-node path, is the preset
    ``lstm-guided@paper``.

    On a height map (``plan_on_map``) the search is guided by the spatial footstep model (``map_model``, a CNN over
    the patch ahead and an LSTM over the past footholds): each node flies the points of its most probable cells
    instead of Step-space's grid, ``map_cells[0]`` of them, then up to ``map_cells[1]`` when the search comes back
    to it, and so on; then (``map_grid_fallback``, the default there: on stepping stones it crosses 72 % of the cases
    against 37 % without, docs/spatial.md) Step-space's grids; ``grid_fallback`` is the planar search's."""

    name = "lstm-guided"

    # many parameters: the planner's options, each set by name in a label's preset (planners.registry.PRESETS)
    def __init__(self, model=SUBCELL_WEIGHTS, branching: int = 3, fallback: tuple = (5,),
                 temperature: float = 1.0, mask_ditches: bool = True, seed: int = 0, lazy: bool = True,
                 conditioning: str = "apex", cost_weights: CostWeights | tuple = CostWeights(),
                 max_nodes: int = MAX_NODES, floor: float = 0.0, grid_fallback: bool = False,
                 map_model=SPATIAL_WEIGHTS, map_cells: tuple = MAP_CELLS, map_grid_fallback: bool = True, **options):
        super().__init__(cost_weights=cost_weights, max_nodes=max_nodes, **options)
        self.map_model, self.map_grid_fallback = map_model, bool(map_grid_fallback)
        self.map_cells = tuple(map_cells)
        if not self.map_cells or not all(isinstance(c, int) and c >= 1 for c in self.map_cells) \
                or any(b <= a for a, b in zip(self.map_cells, self.map_cells[1:])):
            raise ValueError(f"map_cells must be increasing positive integers, got {map_cells!r}")
        for b in (branching, *fallback):
            if not (isinstance(b, int) and b >= 1):
                raise ValueError(f"branching factors must be positive integers, got {b!r}")
        if not temperature > 0:
            raise ValueError(f"temperature must be positive, got {temperature!r}")
        self.net = FootstepDistribution(load_model(model), mask_ditches)
        self.attempts = (branching, *fallback)
        self.temperature = float(temperature)
        self.seed = seed
        self._rng = self._rng_seed = self._rng_start = None   # fresh_rng's generator, made on first use
        self.lazy = bool(lazy)
        if conditioning not in ("path", "apex"):
            raise ValueError(f"conditioning must be 'path' or 'apex', got {conditioning!r}")
        self.conditioning = conditioning
        if not (isinstance(floor, (int, float)) and 0 <= floor < 1):
            raise ValueError(f"floor must be a probability in [0, 1), got {floor!r}")
        self.floor = float(floor)
        self.grid_fallback = bool(grid_fallback)
        self.core_model = self.net.model.arrays if self.conditioning == "apex" else None
        if self.core_model is not None and self.step_map == "fast":
            warm_up_sampled(self)

    def plan_on_map(self, apex, height_map, goal, params=None) -> Plan:
        """The guided search on a height map (``planners.learned.spatial_guided``): the spatial footstep model's
        (``map_model``) most probable cells a node, in the tiers of ``map_cells``, then Step-space's grids where
        ``map_grid_fallback``; with a robustness, at each of its levels
        (``planners.search.spatial_step``)."""
        return plan_on_map(self, apex, height_map, goal, params, self.map_cells, self.map_grid_fallback, self.budget)

    def core_window(self, problem):
        """The compiled core's window settings for ``problem``, None where the search runs in numpy (a terrain
        whose cells are not the model's, the Drake step map, or the path-conditioned model)."""
        if self.core_model is None or self.step_map != "fast":
            return None
        return core_window_settings(problem, self.net, self.temperature, self.floor)

    def searches(self, problem) -> list:
        """(label, search) of each search a planning call tries in turn: the model's searches at each robustness
        level (the grid's after the nominal ones with ``grid_fallback``), then the pruned search."""
        attempts = []
        for r in self.robustness_levels():
            # a lazy search draws the same samples whatever its branching, so a robust level tries it once
            branchings = self.attempts[:1] if r is not None and self.lazy else self.attempts
            attempts += [(f"{attempt_name(r)}B={b}", functools.partial(self._search, problem, b, r))
                         for b in branchings]
            if self.grid_fallback and r is None:  # the whole grid, as Step-space searches it
                attempts += [(f"grid {s:g} m", functools.partial(StepSpacePlanner._search, self, problem, s))
                             for s in self.spacings(problem.units)]
        return attempts + self.pruned_stage(problem)

    def _search(self, problem, branching, robust=None):
        window = self.core_window(problem)
        width = 1 if self.lazy else branching
        if window is None:
            return self.python_search(problem, branching, robust)
        grid = self.expansion(problem, self.spacings(problem.units)[0], problem.window_end)
        expansion = SampledExpansion(*grid, window, self.core_model, self.fresh_rng(), int(width))
        return search(problem, expansion, self.admission(problem, robust), self.n_sequences,
                      self.search_budget(robust))

    def python_search(self, problem, branching, robust=None):
        """The search run as Python (``ModelSamplingExpansion``): the Drake step map's, the path-conditioned
        model's, and, with the apex-conditioned model on the fast step map, the same tree as the compiled search's
        (tests/test_core.py)."""
        expansion = ModelSamplingExpansion(self, problem, 1 if self.lazy else branching)
        return search(problem, expansion, self.admission(problem, robust), self.n_sequences,
                      self.search_budget(robust))

    def fresh_rng(self) -> np.random.Generator:
        """A generator in the state ``np.random.default_rng(self.seed)`` starts in: this planner's one, reset (a
        tenth of making one)."""
        if self._rng is None or self._rng_seed != self.seed:
            self._rng, self._rng_seed = np.random.default_rng(self.seed), self.seed
            self._rng_start = self._rng.bit_generator.state
        self._rng.bit_generator.state = self._rng_start
        return self._rng


class ModelSamplingExpansion:
    """LSTM-guided sampling's expansion run as Python (``planners.core.sampled`` compiles it for the apex-conditioned
    model on the model's cells and the fast step map): the same draws with the path-conditioned model
    (``PathConditionedSampler``), on terrains of other cells, or on the Drake step map. A node's candidates are
    simulated ``width`` at a time in the model's weighted random order (a draw without replacement), more until one
    succeeds, aimed lazily in small chunks; a node with candidates left goes back in the queue (``Children.more``)."""

    def __init__(self, planner: LSTMGuidedPlanner, problem, width: int):
        self.planner, self.problem, self.width = planner, problem, int(width)
        self.grid = planner.expansion(problem, planner.spacings(problem.units)[0], problem.window_end)
        self.sampler = PathConditionedSampler(planner.net, problem, planner.temperature, planner.conditioning)
        self.rng = np.random.default_rng(planner.seed)
        self.draws: dict = {}  # node -> its candidates, angles, weighted order and how far it has been used

    def expand(self, state, tree, size, node, slots):
        """(the node's children, the state: none, this expansion keeps its own)."""
        planner, problem, width = self.planner, self.problem, self.width
        apex = tuple(map(float, tree.apex[node]))
        if node not in self.draws:
            x_l = planner.candidates(apex, problem.terrain, problem.params, self.grid.grid.spacing,
                                     problem.window_end)
            p = np.maximum(self.sampler.probabilities(tree, node, x_l), planner.floor)
            self.draws[node] = {"x": x_l, "theta": np.full(x_l.size, np.nan), "order": weighted_order(p, self.rng),
                                "pos": 0, "ready": []}
        d = self.draws[node]
        x_l, theta, order = d["x"], d["theta"], d["order"]
        ok, apexes = np.zeros(x_l.size, dtype=bool), np.zeros((x_l.size, 3))
        tried, calls = [], 0
        while d["pos"] < order.size or d["ready"]:
            while len(d["ready"]) < width and d["pos"] < order.size:  # aiming is the cost: lazily
                chunk = order[d["pos"]:d["pos"] + 4 * width]
                d["pos"] += chunk.size
                theta[chunk] = planner.aim(apex, x_l[chunk], problem.terrain, problem.params)
                d["ready"] += [i for i in chunk.tolist() if theta[i] == theta[i]]
            batch = np.array(d["ready"][:width], dtype=np.int64)
            d["ready"] = d["ready"][width:]
            tried += batch.tolist()
            ok[batch], apexes[batch] = planner.simulate(problem, apex, x_l[batch], theta[batch])
            calls += batch.size
            if ok[batch].any():
                break
        idx = np.sort(np.array(tried, dtype=np.int64))
        children = children_of(x_l[idx], theta[idx], ok[idx], apexes[idx], calls, self.grid.grid, self.grid.scoring)
        more = bool(d["pos"] < order.size or d["ready"])
        return children._replace(more=more), state


def warm_up_sampled(planner: LSTMGuidedPlanner) -> None:
    """Compile (or load from numba's cache) the planning core's sampled search once per process, with ``planner``'s
    model, so its JIT start-up is not charged to a plan's time budget."""
    if not _COMPILED:
        _COMPILED.append(True)
        problem = planner.problem((0.0, 1.0, 1.0), Terrain.flat(), 1.0, None, time.perf_counter())
        with compiling():
            for robust in (None, Robustness()):
                planner._search(problem, 1, robust)


def core_window_settings(problem, net: FootstepDistribution, temperature: float, floor: float):
    """The compiled core's window settings (``planners.core.sampled.WindowSettings``) for ``problem``, or None
    where the core does not encode the model's window: a terrain whose cells are not the model's."""
    units, terrain = problem.units, problem.terrain
    ahead, behind = units.window
    cell = model_cell(units)
    if abs(terrain.cell - cell) > SAME_CELL * cell:
        return None
    return WindowSettings(float(max(1, int(round((ahead + behind) / terrain.cell)))),
                          float(int(round(behind / terrain.cell))), float(int(round(behind / cell))),
                          float(units.length), float(units.speed), float(min(DITCH_HEIGHT * units.length, 0.0)),
                          float(net.subcells), float(net.mask_ditches), float(temperature), float(floor))
