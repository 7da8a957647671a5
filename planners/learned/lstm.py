"""The learned recurrent planner (paper, section VI): footholds from the CNN+LSTM model, zero ODE calls."""
from __future__ import annotations

import math

import numpy as np

from drakeslip import StepLengthController, Terrain
from drakeslip.state import as_apex
from drakeslip.units import PAPER, units_of

from planners.base import FootstepSequence, Plan, Planner, Problem
from planners.checkpoints import EXPERT_WEIGHTS, PAPER_WEIGHTS, RANKER_WEIGHTS, SPATIAL_WEIGHTS
from planners.learned.inference import PlanningFootstepModel, softmax
from planners.learned.inputs import WindowEncoding, encode_window
from planners.learned.model import FootstepModel, load_checkpoint
from planners.learned.spatial_guided import plan_on_map
from planners.learned.ranker import FootholdRanker, candidate_features, log_probability, top_candidates
from planners.search.step_space import GRID_SPACING
from planners.search.tree import EDGE_MARGIN, check_options, clear_of_edges

_MODELS: dict = {}


def load_model(path=None) -> FootstepModel:
    """The footstep model from ``path`` (default: the paper's, planners/weights/lstm_paper.pt), loaded once."""
    path = str(path or PAPER_WEIGHTS)
    if path not in _MODELS:
        _MODELS[path] = load_checkpoint(path)[0]
    return _MODELS[path]


class FootstepDistribution:
    """Runs the model on one perception window (planners/learned/inference.py). ``mask_ditches`` forbids
    ditch cells (a foot there is a certain FOOT_COLLISION, a physical constraint rather than a terrain
    heuristic)."""

    def __init__(self, model: FootstepModel, mask_ditches: bool = True):
        self.model = PlanningFootstepModel(model)
        self.mask_ditches = mask_ditches

    @property
    def subcells(self) -> int:
        return self.model.config.subcells

    def inputs(self, enc: WindowEncoding):
        """(terrain, apex, s0, mask) as batch-of-one arrays over the model's bins; mask is None when ditches
        are allowed."""
        s0 = np.zeros((1, enc.terrain.size * self.subcells))
        s0[0, enc.s0_bin(self.subcells)] = 1.0
        mask = np.repeat(enc.ditch, self.subcells)[None] if self.mask_ditches else None
        return enc.terrain[None].astype(np.float64), enc.apex[None].astype(np.float64), s0, mask

    def bin_of(self, enc: WindowEncoding, x) -> np.ndarray:
        return enc.bin_of(x, self.subcells)

    def centres(self, enc: WindowEncoding) -> np.ndarray:
        """World x of every bin's centre."""
        return enc.x_of_bin(np.arange(enc.terrain.size * self.subcells), self.subcells)

    def rollout(self, enc: WindowEncoding, n_steps: int, temperature: float = 1.0) -> np.ndarray:
        terrain, apex, s0, mask = self.inputs(enc)
        return self.model.rollout(terrain, apex, s0, n_steps, mask, temperature)[0]


class LSTMPlanner(Planner):
    """Footholds = the mode of each step's distribution, the distribution fed back as the next step's input,
    until a foothold passes the target (at most ``max_steps``); zero step-map calls. The controller executes
    them; the plan holds the first leg angle (from the current apex) and leaves later angles and apexes NaN,
    since the model does not predict them.

    ``model`` is the footstep model's checkpoint file. The defaults are the best shipped setting: one step ahead
    (the receding-horizon loop asks again at every apex), the model trained on the goal-reaching expert's rollouts
    (``EXPERT_WEIGHTS``), and the learned re-ranker's pick (``RANKER_WEIGHTS``). The paper's planner, its model's
    modes for up to 12 steps, is the preset ``lstm@paper``.

    The mode is taken over footholds the hopper can use, on Step-space's grid (GRID_SPACING in the hopper's
    lengths: the bins of a 4-bin sub-cell model; a per-cell model's probabilities interpolated between cell
    centres, so a mode next to a ditch slides away from its edge): ahead of the previous foothold, on solid ground
    at least ``edge_margin`` (None: the paper's EDGE_MARGIN in the hopper's lengths) from an edge, and, for the
    first step, reached by the controller inside the friction cone. The model reads the window in the hopper's
    units (planners/learned/inputs.py). The paper reports
    that its mode often failed on exactly these two counts (friction cone, edges); both can be checked without
    simulating.

    With a ``ranker`` (a weights file of planners/learned/ranker.py, trained for the EXPERT_WEIGHTS model and
    ``max_steps=1``; None: no re-ranking), the first foothold is the ranker's pick among the ``top_k`` most
    probable usable ones rather than the first of them: a learned network evaluation per candidate, still no
    step-map call."""

    name = "lstm"

    # many parameters: the planner's options, each set by name in a label's preset (planners.registry.PRESETS)
    # many parameters: the planner's options, each set by name in a label's preset (planners.registry.PRESETS)
    def __init__(self, model=EXPERT_WEIGHTS, max_steps: int = 1, mask_ditches: bool = True,
                 controller: StepLengthController | None = None, edge_margin: float | None = None,
                 feedback: str = "distribution", ranker=RANKER_WEIGHTS, top_k: int = 5, map_model=SPATIAL_WEIGHTS,
                 **budget):
        super().__init__(**budget)
        self.map_model = map_model
        if feedback not in ("distribution", "mode"):
            raise ValueError(f"feedback must be 'distribution' or 'mode', got {feedback!r}")
        self.feedback = feedback
        if not (isinstance(max_steps, int) and max_steps >= 1):
            raise ValueError(f"max_steps must be a positive integer, got {max_steps!r}")
        self.model = load_model(model)
        self.net = FootstepDistribution(self.model, mask_ditches)
        self.max_steps = max_steps
        self.controller = controller or StepLengthController.load_default()
        self.edge_margin = check_options(None, edge_margin)[1]
        if not (isinstance(top_k, int) and top_k >= 1):
            raise ValueError(f"top_k must be a positive integer, got {top_k!r}")
        self.top_k = top_k
        self.ranker = None if ranker is None else FootholdRanker(ranker)

    def plan_on_map(self, apex, height_map, goal, params=None) -> Plan:
        """The model's most probable cell at every node, flown on the spatial step map, with little backtracking
        (``planners.learned.spatial_guided``; ``map_model`` the spatial footstep model)."""
        return plan_on_map(self, apex, height_map, goal, params, (1,), False, self.budget)

    def distributions(self, apex, terrain: Terrain, n: int, temperature: float = 1.0, params=None):
        """Per-step probabilities over the window's bins (its cells, or their parts for a sub-cell model),
        (n, bins), and the bins' centres x (bins,), for the hopper ``params`` (default: the paper's)."""
        apex = as_apex(apex)
        enc = encode_window(terrain, apex, units_of(params or PAPER))
        return self.net.rollout(enc, n, temperature), self.net.centres(enc)

    def _plan(self, problem: Problem) -> Plan:
        terrain, params, apex, units = problem.terrain, problem.params, problem.apex, problem.units
        enc = encode_window(terrain, apex, units)
        model = self.net.model
        window, apex_in, prev, mask = self.net.inputs(enc)
        state = model.initial_state(apex_in)
        centres = self.net.centres(enc)
        spacing = GRID_SPACING * units.length
        first = math.ceil((apex.x - params.leg_length - terrain.x0) / spacing - 0.5)
        last = math.floor((problem.window_end - terrain.x0) / spacing - 0.5)
        grid = terrain.x0 + (np.arange(first, last + 1) + 0.5) * spacing
        edge_margin = units.length_or(self.edge_margin, EDGE_MARGIN)
        usable = (terrain.height_at(grid) > terrain.ditch_height) & clear_of_edges(terrain, grid, edge_margin)
        footholds, behind = [], -math.inf
        for _ in range(self.max_steps):
            logits, state = model.step(window, prev, state)
            p = softmax(logits, mask)
            score = np.where(usable & (grid > behind), np.interp(grid, centres, p[0]), 0.0)
            if not footholds:
                score = self.pick_first(problem, grid, *self._reachable(problem, grid, score))
            if not score.any():
                break
            footholds.append(behind := float(grid[score.argmax()]))
            if behind >= problem.target_x:
                break
            if self.feedback == "mode":
                prev = np.zeros_like(p)
                prev[0, self.net.bin_of(enc, behind)] = 1.0
            else:
                prev = p
        if not footholds:
            return Plan(self.name, False, problem.target_x, message="no plan found: no usable first foothold "
                        "has probability under the model")
        footholds = np.array(footholds)
        angles = np.full(footholds.size, np.nan)
        angles[0] = self.controller.for_params(params).leg_angle(apex, footholds[0], terrain)
        seq = FootstepSequence(footholds, angles, np.full((footholds.size, 3), np.nan))
        return Plan(self.name, True, problem.target_x, sequences=[seq])

    def pick_first(self, problem: Problem, grid, score, theta):
        """``score`` kept only on the ranker's pick among the ``top_k`` most probable first footholds (unchanged
        without a ranker); ``theta``: the controller's leg angles to ``grid``, from ``_reachable``."""
        top = top_candidates(score, self.top_k)
        if self.ranker is None or top.size < 2:
            return score
        features = candidate_features(problem, grid[top], log_probability(score, top), theta[top])
        pick = top[int(np.argmax(self.ranker.scores(features)))]
        return np.where(np.arange(score.size) == pick, score, 0.0)

    def _reachable(self, problem: Problem, grid, score, tries: int = 32):
        """(``score`` kept only on the best ``tries`` first footholds the controller reaches inside the friction
        cone, the controller's leg angles to ``grid``: NaN where not aimed)."""
        order = np.argsort(-score)[:tries]
        order = order[score[order] > 0]
        kept, theta = np.zeros_like(score), np.full(score.size, np.nan)
        if order.size:
            theta[order] = self.controller.for_params(problem.params).leg_angles(problem.apex, grid[order],
                                                                                problem.terrain)
            ok = np.abs(np.nan_to_num(theta[order], nan=np.inf)) < math.atan(problem.params.friction)
            kept[order[ok]] = score[order[ok]]
        return kept, theta
