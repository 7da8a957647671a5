"""LSTM-guided sampling (paper, section VI-A): the Step-space search with children sampled from the LSTM's
distribution over the next foothold, given the path from the root to the node being expanded."""
from __future__ import annotations

import time

import numpy as np

from drakeslip import ApexState, Terrain
from drakeslip.compiled import compiling
from drakeslip.terrain import DITCH_HEIGHT

from planners.checkpoints import SUBCELL_WEIGHTS
from planners.core.model import ModelArrays
from planners.learned.inference import softmax
from planners.learned.inputs import SAME_CELL, encode_window, model_cell
from planners.learned.lstm import FootstepDistribution, load_model
from planners.search.robust import Robustness
from planners.search.step_space import StepSpacePlanner, attempt_name
from planners.search.tree import Children, CostWeights, best_first, run_attempts

# Node budget of each search attempt: a node costs several times a Step-space node (an LSTM step besides the
# controller and the step map), so this bounds a call that finds no plan to a few seconds as Step-space's does.
MAX_NODES = 500
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
    ``lstm-guided@paper``."""

    name = "lstm-guided"

    def __init__(self, model=SUBCELL_WEIGHTS, branching: int = 3, fallback: tuple = (5,),
                 temperature: float = 1.0, mask_ditches: bool = True, seed: int = 0, lazy: bool = True,
                 conditioning: str = "apex", cost_weights: CostWeights | tuple = CostWeights(),
                 max_nodes: int = MAX_NODES, floor: float = 0.0, grid_fallback: bool = False, **options):
        super().__init__(cost_weights=cost_weights, max_nodes=max_nodes, **options)
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
        self.core_model = ModelArrays(self.net.model_weights) if self.conditioning == "apex" else None
        if self.core_model is not None and self.step_map == "fast":
            warm_up_sampled(self)

    def core_window(self, problem):
        """The compiled core's window settings for ``problem``, None where the search runs in numpy (a terrain
        whose cells are not the model's, the Drake step map, or the path-conditioned model)."""
        if self.core_model is None or self.step_map != "fast":
            return None
        return core_window_settings(problem, self.net, self.temperature, self.floor)

    def _plan(self, problem):
        attempts = []
        for r in self.robustness_levels():
            # a lazy search draws the same samples whatever its branching, so a robust level tries it once
            branchings = self.attempts[:1] if r is not None and self.lazy else self.attempts
            attempts += [(f"{attempt_name(r)}B={b}", lambda b=b, r=r: self._search(problem, b, r))
                         for b in branchings]
            if self.grid_fallback and r is None:  # the whole grid, as Step-space searches it
                attempts += [(f"grid {s:g} m", lambda s=s: StepSpacePlanner._search(self, problem, s))
                             for s in self.spacings(problem.units)]
        return run_attempts(self, problem, attempts + self.pruned_stage(problem))

    def _search(self, problem, branching, robust=None):
        window = self.core_window(problem)
        if window is not None:
            from planners.core.search import sampled_search  # compiled on first use: imports stay light

            settings = self.core_settings(problem, self.spacings(problem.units)[0], problem.window_end)
            return sampled_search(problem, settings, window, self.core_model, self.fresh_rng(),
                                  1 if self.lazy else branching, robust, self.controller.for_params(problem.params),
                                  self.cost_weights, self.n_sequences, self.search_budget(robust), problem.timing)
        return self.numpy_search(problem, branching, robust)

    def fresh_rng(self) -> np.random.Generator:
        """A generator in the state ``np.random.default_rng(self.seed)`` starts in: this planner's one, reset (a
        tenth of making one)."""
        if self._rng is None or self._rng_seed != self.seed:
            self._rng, self._rng_seed = np.random.default_rng(self.seed), self.seed
            self._rng_start = self._rng.bit_generator.state
        self._rng.bit_generator.state = self._rng_start
        return self._rng

    def numpy_search(self, problem, branching, robust=None):
        """The search in Python (``best_first`` expanding with the sampler, ``aim`` and ``simulate``): the Drake
        step map's, the path-conditioned model's, and the reference whose trees the compiled core makes."""
        sampler = PathConditionedSampler(self.net, problem, self.temperature, self.conditioning)
        terrain, params = problem.terrain, problem.params
        rng = np.random.default_rng(self.seed)
        draws: dict = {}  # node -> its candidates, angles, LSTM-weighted order and how far it has been used

        def expand(tree, node) -> Children:
            """Simulate the node's next ``branching`` admissible candidates in LSTM-weighted random order (a
            weighted draw without replacement), more until one succeeds; candidates are aimed lazily, in small
            chunks. A node with candidates left goes back in the queue (Children.more)."""
            if node not in draws:
                apex = tree.apex[node]
                x_l = self.candidates(apex, terrain, params, self.spacings(problem.units)[0], problem.window_end)
                order = weighted_order(np.maximum(sampler.probabilities(tree, node, x_l), self.floor), rng)
                draws[node] = {"x": x_l, "theta": np.full(x_l.size, np.nan), "order": order, "pos": 0, "ready": []}
            d = draws[node]
            apex, x_l, theta, order = tree.apex[node], d["x"], d["theta"], d["order"]
            ok, apexes = np.zeros(x_l.size, dtype=bool), np.zeros((x_l.size, 3))
            tried, calls = [], 0
            width = 1 if self.lazy else branching
            while d["pos"] < order.size or d["ready"]:
                while len(d["ready"]) < width and d["pos"] < order.size:  # aiming is the cost: lazily
                    chunk = order[d["pos"]:d["pos"] + 4 * width]
                    d["pos"] += chunk.size
                    theta[chunk] = self.aim(apex, x_l[chunk], terrain, params)
                    d["ready"] += [i for i in chunk.tolist() if theta[i] == theta[i]]
                batch = np.array(d["ready"][:width], dtype=np.int64)
                d["ready"] = d["ready"][width:]
                tried += batch.tolist()
                ok[batch], apexes[batch] = self.simulate(problem, apex, x_l[batch], theta[batch])
                calls += batch.size
                if ok[batch].any():
                    break
            idx = np.sort(np.array(tried, dtype=np.int64))
            children = self.children(problem, x_l[idx], theta[idx], ok[idx], apexes[idx], calls)
            children.more = bool(d["pos"] < order.size or d["ready"])
            return children

        return best_first(problem, expand, self.cost_weights, self.n_sequences, self.search_budget(robust),
                          self.admission(problem, robust))


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
    """The compiled core's window settings (``planners.core.sampled``'s N_CELLS..FLOOR) for ``problem``, or None
    where the core does not encode the model's window: a terrain whose cells are not the model's."""
    units, terrain = problem.units, problem.terrain
    ahead, behind = units.window
    cell = model_cell(units)
    if abs(terrain.cell - cell) > SAME_CELL * cell:
        return None
    return np.array([max(1, int(round((ahead + behind) / terrain.cell))), int(round(behind / terrain.cell)),
                     int(round(behind / cell)), units.length, units.speed, min(DITCH_HEIGHT * units.length, 0.0),
                     net.subcells, net.mask_ditches, temperature, floor], dtype=np.float64)


def weighted_order(p: np.ndarray, rng) -> np.ndarray:
    """The indices with p > 0 in the order of a weighted draw without replacement (Efraimidis and Spirakis:
    sort by u^(1/p), u uniform)."""
    idx = np.flatnonzero(p > 0)
    keys = np.log(rng.uniform(size=idx.size)) / p[idx]
    return idx[np.argsort(-keys)]
