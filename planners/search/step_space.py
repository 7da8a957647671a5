"""The Step-space planner: the Angle-space search with children from a grid of desired footholds passed
through the low-level controller (paper, section V-C), so every planned step is one the controller hits."""
from __future__ import annotations

import copy
import functools
import math
import time
from dataclasses import replace

import numpy as np

from drakeslip import StepLengthController, Terrain, step, step_batch
from drakeslip.bounds import CELL, LEG_LENGTH, Bound
from drakeslip.compiled import compiling
from drakeslip.params import check_count, check_number, shown
from drakeslip.stepmap import STEP_MAP_BACKENDS
from drakeslip.units import HopperUnits, units_of

from planners.base import MAX_NODES, Budget, Plan, Planner, Problem
from planners.core.grid import (GridExpansion, GridSettings, Reach, aim_candidates, children_of, grid_candidates,
                                reach_bounds)
from planners.search.pruned import MAX_NODES as PRUNED_NODES
from planners.search.pruned import pruned_search
from planners.core.robust import no_check
from planners.search.loop import search
from planners.search.robust import LOOKAHEAD_ANGLES, Robustness
from planners.search.spatial_problem import spatial_problem
from planners.search.spatial_step import SpatialStepSettings, check_fast_step_map, plan_step_space
from planners.search.tree import (DISTANCES, EDGE_MARGIN, FRICTION_MARGIN, ISOLATION_AT_FAILURE, MIN_SPEED,
                                  REACH_ANGLES, Attempts, CostWeights, SearchResult, check_options, check_weights)

# The paper's hopper's settings [m] (a search uses them in its hopper's lengths, see planners.base.Planner):
GRID_SPACING = 0.025       # the foothold grid: a quarter of the paper's 10 cm cells
FALLBACK_SPACINGS = (0.01,)
TOLERANCE = 0.02           # a hop must land this close to its desired foothold
REACH_PAD = 0.3            # added to the reach on both sides: level changes move touchdowns by up to this
# The fraction of the edge margin a robust planner's last search keeps when no search with the full margin finds a
# sequence: a robot left without a plan fails for sure, and one whose noisy map or apex puts the only footholds
# past a ditch a few millimetres inside the margin can still make it.
LAST_RESORT_MARGIN = 0.25
# Bounds of the options given in metres or m/s (None, the default, is the paper's value in the hopper's units). Each
# holds for every hopper of drakeslip.bounds (a planner is built before it is told its hopper) and lies far outside
# every setting used (grids of 1-2.5 cm, tolerances and margins of 2-30 cm). A grid spacing: from the finest map cell
# (CELL, 1 mm; a finer grid holds footholds no map or aim tells apart, and unbounded candidates) to the longest leg
# (LEG_LENGTH): a leg reaches about two leg lengths a hop, so a wider grid leaves it one foothold a hop or none.
SPACINGS = Bound(CELL.low, LEG_LENGTH.high, "m")


def check_spacing(value, name: str) -> float:
    """``value`` [m] as a float if it lies in SPACINGS; else ValueError naming ``name`` and the value."""
    try:
        return check_number(value, name, bound=SPACINGS)
    except ValueError:   # the words the planner always gave, then the bound
        raise ValueError(f"{name} must be a positive distance, got {shown(value)}: grid spacings lie in "
                         f"{SPACINGS}") from None


class StepSpacePlanner(Planner):
    """Children: desired footholds x_L on a grid of ``spacing`` (x0 + (i + 1/2) spacing from the terrain's start;
    default 2.5 cm in the hopper's lengths, a quarter of the paper's 10 cm cells, so the grid is the hopper's
    whatever the terrain's cells) between the touchdowns of the extreme friction-cone angles, +-0.3 m (in the
    hopper's lengths) for the terrain. The paper used 0.5 m over a 5 m horizon; a 0.5 m leg reaches about 1 m per
    hop, and at low speed the footholds that keep the next hop alive span only 10-15 cm, so a fine grid is what
    finds them.
    Ditch cells, x_L within ``edge_margin`` of an edge, and x_L the controller can only reach outside the
    friction cone are dropped before simulation; the rest go through the controller and one batched fast
    step-map call, and a child is kept when the hop succeeds, lands within ``tolerance`` of x_L and keeps
    ``min_speed``. The plan's footholds are the x_L. If a search finds no sequence it is retried on each
    ``fallback_spacing`` grid (like the paper's fallback branching; default 1 cm in the hopper's lengths): a fast,
    high hop keeps its next hop alive only for footholds in a band 2-3 cm wide, which the 1 cm grid finds. Every
    length and speed option left at None is the paper's value (GRID_SPACING, FALLBACK_SPACINGS, TOLERANCE,
    MIN_SPEED, EDGE_MARGIN) in the hopper's units; one given is in metres or m/s, refused outside its bound.

    ``robustness`` (a ``planners.search.robust.Robustness``, or its fields as a dict) keeps only children that
    also work in its perturbed scenarios (state, actuation, model and terrain errors) and leave the hopper where
    it can go on, so the plan keeps the margins a noisy robot needs. The check runs when the search pops a node
    (``admission``), so a search that finds a robust sequence straight away flies the perturbed robots over that
    sequence alone; each robustness level searches the coarse grid within its own node budget, then the next
    level, then (``fallback_nominal``) the nominal search; the plan's message says which found it.

    When every search finds nothing, the last stage (``planners.search.pruned``) searches on from the start with the
    oracle's pruning (the energy graph, merged apexes, progress minus risk) for up to ``pruned_nodes`` expansions
    (default PRUNED_NODES; 0 skips it): starts with little energy before high steps have plans of many slow hops that
    the nominal order does not reach. It runs on the fast step map, after the nominal search (not after robust levels
    alone: ``fallback_nominal=False``); the plan's message then says "found by pruned search". After it, a robust
    planner (``robustness`` with ``fallback_nominal``) runs the nominal search once more with footholds only
    ``last_resort_margin`` of ``edge_margin`` from an edge (default LAST_RESORT_MARGIN; None skips it): a robot left
    without a plan fails for sure, and one whose noisy map or apex puts the only footholds past a ditch a few
    millimetres inside the margin can still make it; the message then names that edge margin. Where even that
    finds nothing, a planner with ``safe_hops`` returns the safest branch its searches grew (``Plan.safe_hops``,
    ``planners.search.tree.Attempts``): hops that keep the hopper alive while it regains the energy or position
    from which a plan exists, rather than no hop at all.

    ``step_map="drake"`` simulates every candidate on the Drake hybrid simulator instead of the fast step map
    (about 0.1 s a hop against 5 us): planning on the reference model, where a plan's time is its ODE
    calls, as it was for the paper's planners. Give it a ``max_time_s`` to match. Either way the search is the one
    best-first loop (``planners.search.tree.search``): compiled with the compiled grid expansion
    (``planners.core.grid``), or as Python with ``PythonGridExpansion``, the same expansion on the Drake step map."""

    name = "step"

    # many parameters: the planner's options, each set by name in a label's preset (planners.registry.PRESETS)
    def __init__(self, controller: StepLengthController | None = None, spacing: float | None = None,
                 tolerance: float | None = None, fallback_spacing: tuple | None = None, n_sequences: int = 1,
                 cost_weights: CostWeights | tuple = CostWeights(), min_speed: float | None = None,
                 edge_margin: float | None = None, step_map: str = "fast",
                 robustness: Robustness | dict | None = None, fallback_nominal: bool = True,
                 pruned_nodes: int = PRUNED_NODES, last_resort_margin: float | None = LAST_RESORT_MARGIN,
                 safe_hops: bool = False, **budget):
        super().__init__(**budget)
        self.spacing = None if spacing is None else check_spacing(spacing, "spacing")
        if fallback_spacing is not None and not isinstance(fallback_spacing, (tuple, list)):
            raise ValueError(f"fallback_spacing must be a list of spacings [m] or None, got {shown(fallback_spacing)}")
        self.fallback_spacing = None if fallback_spacing is None else tuple(
            check_spacing(s, f"fallback_spacing[{i}]") for i, s in enumerate(fallback_spacing))
        self.tolerance = None if tolerance is None else check_number(tolerance, "tolerance", positive=True,
                                                                     bound=DISTANCES)
        self.min_speed, self.edge_margin = check_options(min_speed, edge_margin)
        self.n_sequences = check_count(n_sequences, "n_sequences")
        self.cost_weights = check_weights(cost_weights)
        self.pruned_nodes = check_count(pruned_nodes, "pruned_nodes", low=0, high=MAX_NODES)
        if last_resort_margin is not None and not 0 <= check_number(last_resort_margin, "last_resort_margin") < 1:
            raise ValueError(f"last_resort_margin must be in [0, 1) or None, got {shown(last_resort_margin)}")
        self.last_resort_margin = last_resort_margin
        try:
            self.robustness = Robustness(**robustness) if isinstance(robustness, dict) else robustness
        except TypeError as error:   # an unknown field
            raise ValueError(f"robustness: {error}") from None
        if self.robustness is not None and not isinstance(self.robustness, Robustness):
            raise ValueError(f"robustness must be a Robustness or a dict of its fields, got {shown(robustness)}")
        for name, flag in (("fallback_nominal", fallback_nominal), ("safe_hops", safe_hops)):
            if not isinstance(flag, (bool, np.bool_)):   # bool("false") is True
                raise ValueError(f"{name} must be true or false, got {shown(flag)}")
        self.fallback_nominal, self.safe_hops = bool(fallback_nominal), bool(safe_hops)
        if not isinstance(step_map, str) or step_map not in STEP_MAP_BACKENDS:
            raise ValueError(f"unknown step_map {shown(step_map)}; choose one of {STEP_MAP_BACKENDS}")
        self.step_map = step_map
        if controller is not None and not isinstance(controller, StepLengthController):
            raise ValueError(f"controller must be a StepLengthController or None, got {shown(controller)}")
        self.controller = controller or StepLengthController.load_default()
        if step_map == "fast":   # the core holds its own step map; the Python search simulates on Drake
            warm_up_core()

    def plan_on_map(self, apex, height_map, goal, params=None) -> Plan:
        """Step-space on a height map (``planners.search.spatial_step``) with this planner's grid, tolerance, margins,
        cost weights, budget, robustness (its noise, sigmas and friction loss: particles that must survive each hop;
        its planar fields are refused, ``spatial_step.check_map_robustness``) and safe hops; the Drake step map, a
        planar option, is refused in one line."""
        t0 = time.perf_counter()
        check_fast_step_map(self)
        problem = spatial_problem(apex, height_map, goal, params, self.horizon, t0, self.budget.max_time_s)
        settings = SpatialStepSettings(self.spacing, self.fallback_spacing, self.tolerance, self.edge_margin,
                                       self.min_speed, self.cost_weights, self.n_sequences,
                                       robustness=self.robustness, fallback_nominal=self.fallback_nominal,
                                       safe_hops=self.safe_hops)
        plan = plan_step_space(problem, settings, self.budget, self.name)
        plan.time_s = time.perf_counter() - t0
        problem.timing.total = plan.time_s
        plan.timing = problem.timing.record()
        return plan

    def spacings(self, units: HopperUnits) -> tuple:
        """The grid spacings [m] a search tries in turn for a hopper of ``units``: ``spacing``, then each
        ``fallback_spacing``."""
        fallback = self.fallback_spacing
        if fallback is None:
            fallback = tuple(s * units.length for s in FALLBACK_SPACINGS)
        return (units.length_or(self.spacing, GRID_SPACING), *fallback)

    def grid_settings(self, problem: Problem, spacing: float, until: float = math.inf) -> GridSettings:
        """The grid of ``spacing`` for ``problem``, its footholds up to ``until``."""
        units = problem.units
        return GridSettings(float(spacing), REACH_PAD * units.length, float(until),
                            units.length_or(self.edge_margin, EDGE_MARGIN), math.atan(problem.params.friction),
                            units.length_or(self.tolerance, TOLERANCE), units.speed_or(self.min_speed, MIN_SPEED),
                            float(problem.window_end), ISOLATION_AT_FAILURE * units.length)

    def expansion(self, problem: Problem, spacing: float, until: float = math.inf) -> GridExpansion:
        """The compiled grid expansion of ``problem`` on the grid of ``spacing``."""
        return GridExpansion(self.grid_settings(problem, spacing, until), problem.terrain.ground(),
                             problem.params.as_array(), self.controller.for_params(problem.params).arrays(),
                             reach_angles(problem.params), self.cost_weights.scoring(problem), problem.before)

    def candidates(self, apex, terrain, params, spacing: float | None, until: float | None = None) -> np.ndarray:
        """Desired footholds within reach of ``apex``, on the grid x0 + (i + 1/2) * spacing (None: the planner's
        first grid for ``params``), up to ``until`` if given. The planner itself asks for the full reach: hops that
        would land past the perception window are simulated too, to tell a sequence that has gone as far as the
        robot can see (see ``planners.core.best_first``)."""
        units = units_of(params)
        grid = GridSettings(spacing or self.spacings(units)[0], REACH_PAD * units.length,
                            math.inf if until is None else until, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        return grid_candidates(*map(float, apex), terrain.ground(), params.as_array(), reach_angles(params), grid)

    def aim(self, apex, x_l: np.ndarray, terrain, params) -> np.ndarray:
        """The controller's leg angle to each desired foothold, NaN where the foothold is not admissible: a
        ditch cell, within ``edge_margin`` of an edge, or reached only outside the friction cone. Telling these
        apart needs no step-map call."""
        edge_margin = units_of(params).length_or(self.edge_margin, EDGE_MARGIN)
        return aim_candidates(*map(float, apex), np.asarray(x_l, dtype=np.float64), terrain.ground(),
                              self.controller.for_params(params).arrays(), edge_margin, math.atan(params.friction))

    def search(self, apex, terrain, goal_x, params=None) -> SearchResult:
        """One search on each grid in turn until one finds a sequence; the result's tree holds every node the
        last search created."""
        problem = self.problem(apex, terrain, goal_x, params, time.perf_counter())
        for robust, spacing in self.attempt_settings(problem.units):
            result = self._search(problem, spacing, robust)
            if result.tree.goals or result.stop == "time":
                break
        return result

    def robustness_levels(self) -> list:
        """What each round of attempts asks for, in order: ``robustness`` and its relaxed levels, then (with
        ``fallback_nominal``) none."""
        if self.robustness is None:
            return [None]
        return self.robustness.levels() + ([None] if self.fallback_nominal else [])

    def attempt_settings(self, units: HopperUnits) -> list:
        """(robustness or None, grid spacing) of each search attempt for a hopper of ``units``, in order: the most
        robust first."""
        return [(r, s) for r in self.robustness_levels() for s in self.grids(r, units)]

    def grids(self, robust: Robustness | None, units: HopperUnits) -> tuple:
        """The grid spacings searched in turn at a robustness level: the fallback grids only without one or
        where it asks for them (``Robustness.fallback_grids``). They exist for the narrow bands of fast nominal
        hops; at every robust level they would double what a level with no robust sequence costs before the next
        one is tried."""
        spacings = self.spacings(units)
        return spacings if robust is None or robust.fallback_grids else spacings[:1]

    def _search(self, problem: Problem, spacing, robust: Robustness | None = None) -> SearchResult:
        if self.step_map != "fast":
            return self.python_search(problem, spacing, robust)
        return search(problem, self.expansion(problem, spacing), self.admission(problem, robust), self.n_sequences,
                      self.search_budget(robust))

    def python_search(self, problem: Problem, spacing, robust: Robustness | None = None) -> SearchResult:
        """The search run as Python, its candidates flown on the planner's step map one call at a time
        (``PythonGridExpansion``): the Drake step map's search; on the fast step map, the same tree as the compiled
        search's (tests/test_core.py)."""
        return search(problem, PythonGridExpansion(self, problem, spacing), self.admission(problem, robust),
                      self.n_sequences, self.search_budget(robust))

    def search_budget(self, robust: Robustness | None):
        """The planner's budget, its nodes capped at ``robust.max_nodes`` for a robust search."""
        if robust is None or robust.max_nodes >= self.budget.max_nodes:
            return self.budget
        return replace(self.budget, max_nodes=robust.max_nodes)

    def simulate(self, problem: Problem, apex, x_l: np.ndarray, theta: np.ndarray):
        """One batched fast step-map call (or one Drake simulation each) for the admissible (finite ``theta``)
        desired footholds; returns ``ok`` (the hop succeeds, lands within ``tolerance`` of x_L and keeps
        ``min_speed``) and the next apexes."""
        keep = ~np.isnan(theta)
        ok = np.zeros(x_l.size, dtype=bool)
        apexes = np.zeros((x_l.size, 3))
        if not keep.any():
            return ok, apexes
        if self.step_map == "fast":
            res = step_batch(apex, theta[keep], problem.terrain, problem.params)
            landed, touchdown_x = res.ok, res.touchdown_x
            apexes[keep] = np.stack([res.next_x, res.next_z, res.next_xdot], axis=1)
        else:
            hops = [step(apex, a, problem.terrain, problem.params, backend="drake") for a in theta[keep]]
            landed = np.array([h.ok for h in hops])
            touchdown_x = np.array([h.touchdown_x for h in hops])
            apexes[keep] = [h.next_apex if h.ok else h.end_state[:3] for h in hops]
        units = problem.units
        tolerance, min_speed = units.length_or(self.tolerance, TOLERANCE), units.speed_or(self.min_speed, MIN_SPEED)
        ok[keep] = landed & (np.abs(touchdown_x - x_l[keep]) < tolerance) & (apexes[keep, 2] >= min_speed)
        return ok, apexes

    def admission(self, problem: Problem, robust: Robustness | None):
        """The search's check of each node it pops (``planners.core.robust``): the particles of ``robust`` that
        reached the node's parent fly to its foothold, and a node of the sequence's first ``robust.depth`` hops is
        kept only if all of them make it; without ``robust`` every node is kept. Checked lazily, one node at a time
        as the search reaches it, so a search that finds a robust sequence straight away flies the particles over
        that sequence alone."""
        controller = self.controller.for_params(problem.params).arrays()
        if robust is None:
            return no_check(problem.terrain.ground(), controller, problem.before)
        return robust.admission(problem.apex, problem.terrain, problem.params, controller, problem.before)

    def last_resort(self, units: HopperUnits) -> "StepSpacePlanner | None":
        """This planner without robustness, its edge margin ``last_resort_margin`` of its own, for a hopper of
        ``units``: what a robust planner searches last; None without ``robustness``, ``fallback_nominal`` or
        ``last_resort_margin``."""
        if self.robustness is None or not self.fallback_nominal or self.last_resort_margin is None:
            return None
        tight = copy.copy(self)
        tight.robustness = None
        tight.edge_margin = self.last_resort_margin * units.length_or(self.edge_margin, EDGE_MARGIN)
        return tight

    def _plan(self, problem: Problem) -> Plan:
        tried = Attempts(self.name, problem.target_x, self.safe_hops)
        for label, attempt in self.searches(problem):
            if tried.ended(label, attempt()):
                break
        return tried.plan()

    def searches(self, problem: Problem) -> list:
        """(label, search) of each search a planning call tries in turn: the grids at each robustness level, the
        pruned search, then the last resort's grids."""
        attempts = [(f"{attempt_name(r)}grid {s:g} m", functools.partial(self._search, problem, s, r))
                    for r, s in self.attempt_settings(problem.units)] + self.pruned_stage(problem)
        tight = self.last_resort(problem.units)
        if tight is not None:
            attempts += [(f"edge margin {tight.edge_margin:.3g} m grid {s:g} m",
                          functools.partial(tight._search, problem, s, None)) for s in tight.spacings(problem.units)]
        return attempts

    def pruned_stage(self, problem: Problem) -> list:
        """The pruned search's attempt, [("pruned search", thunk)], where the planner runs one (see the class doc):
        [] without."""
        if not self.pruned_nodes or self.step_map != "fast" or self.robustness_levels()[-1] is not None:
            return []

        def attempt():
            expansion = self.expansion(problem, self.spacings(problem.units)[0])
            return pruned_search(problem, expansion, self.pruned_nodes)

        return [("pruned search", attempt)]


class PythonGridExpansion:
    """Step-space's grid expansion (``planners.core.grid``), its candidates flown by ``StepSpacePlanner.simulate``
    (on the Drake hybrid simulator, or the fast step map): the expansion of the search run as Python."""

    def __init__(self, planner: StepSpacePlanner, problem: Problem, spacing: float):
        self.planner, self.problem = planner, problem
        self.record = planner.expansion(problem, spacing)

    def expand(self, state, tree, size, node, slots):
        """(the node's children, the state: none, this expansion keeps its own)."""
        apex, record, problem = tree.apex[node], self.record, self.problem
        x_l = grid_candidates(*map(float, apex), record.ground, record.params, record.reach, record.grid)
        theta = aim_candidates(*map(float, apex), x_l, record.ground, record.controller, record.grid.edge_margin,
                               record.grid.max_angle)
        ok, apexes = self.planner.simulate(problem, apex, x_l, theta)
        calls = int(np.count_nonzero(~np.isnan(theta)))
        return children_of(x_l, theta, ok, apexes, calls, record.grid, record.scoring), state


@functools.cache
def warm_up_core() -> None:
    """Compile (or load from numba's cache) the planning core's grid search once per process, so its JIT start-up is
    not charged to a plan's time budget. The pruned stage, which a plan reaches only where the searches find
    nothing, is compiled when first used (``planners.search.pruned``)."""
    planner = StepSpacePlanner(max_nodes=1, step_map="drake")  # a planner that does not warm up the core itself
    planner.step_map = "fast"
    problem = planner.problem((0.0, 1.0, 1.0), Terrain.flat(), 1.0, None, time.perf_counter())
    planner.budget = Budget(max_nodes=1)
    with compiling():
        for robust in (None, Robustness()):
            planner._search(problem, GRID_SPACING, robust)


def attempt_name(robustness: Robustness | None) -> str:
    """How a plan's message names the robustness its search asked for."""
    if robustness is None:
        return ""
    fan = "" if robustness.lookahead_angles == LOOKAHEAD_ANGLES else f", fan {robustness.lookahead_angles}"
    return f"robust ({robustness.sigmas:g} sigma, depth {robustness.depth}{fan}) "


@functools.lru_cache(maxsize=64)
def reach_angles(params) -> Reach:
    """Sines and cosines of the reach angles (a grid across the friction cone, REACH_ANGLES of FRICTION_MARGIN of
    its half-angle) of the hopper ``params``, computed once per hopper."""
    angles = REACH_ANGLES * FRICTION_MARGIN * math.atan(params.friction)
    return Reach(np.sin(angles), np.cos(angles))


def touchdown_range(x: float, z: float, v: float, terrain, params) -> tuple[float, float]:
    """Bounds on where a flight from apex (x, z, v) can touch down on solid ground with a leg angle inside the
    friction cone (``planners.core.grid.reach_bounds``)."""
    return reach_bounds(float(x), float(z), float(v), terrain.ground(), params.as_array(), reach_angles(params))
