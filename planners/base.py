"""What every planner shares: the Plan it returns, its budget, and input checks (one OMPL-style interface)."""
from __future__ import annotations

import inspect
import time
from abc import ABC, abstractmethod
from pathlib import Path
from dataclasses import dataclass, field

import numpy as np

from drakeslip import ApexState, SlipParams, Terrain
from drakeslip.bounds import HORIZON, POSITION
from drakeslip.params import check_count, check_number
from drakeslip.spatial.heightmap import HeightMap
from drakeslip.state import check_apex
from drakeslip.terrain import WINDOW_AHEAD
from drakeslip.units import HopperUnits, units_of

# The plan aims this far short of the window's end when the goal lies beyond the window: the last footholds
# must still be inside what the robot can see, and the hop after them needs ground under it too. [m] for the
# paper's hopper; a planner uses it in its hopper's lengths (``HopperUnits``), as it does every setting below.
TARGET_MARGIN = 1.0


@dataclass
class FootstepSequence:
    """Footholds x_i [m], the leg angles that reach them, and the predicted apex (x, z, xdot) after each; on a height
    map footholds (x, y, z), leg angles (pitch, roll) and apexes (x, y, z, xdot, ydot), a row each."""

    footholds: np.ndarray
    leg_angles: np.ndarray
    apexes: np.ndarray

    def __len__(self):
        return len(self.footholds)

    def to_dict(self) -> dict:
        return {"footholds": self.footholds.tolist(), "leg_angles": self.leg_angles.tolist(),
                "apexes": self.apexes.tolist()}


@dataclass
class Timing:
    """Where a planning call's time went [s]: the step map, the controller, the footstep model, and the search
    around them (the frontier, the tree, the candidates, the Python around the compiled core: the call's
    wall-clock ``total`` less the three)."""

    step_map: float = 0.0
    controller: float = 0.0
    model: float = 0.0
    total: float = 0.0
    accounted: bool = False  # a compiled core ran and added its time

    def add(self, slots) -> None:
        """Add a compiled core's time slots (step map, controller, model; planners/core/clock.py)."""
        self.accounted = True
        self.step_map += float(slots[0])
        self.controller += float(slots[1])
        self.model += float(slots[2])

    def record(self) -> dict:
        """The breakdown as a results file holds it."""
        search = max(self.total - self.step_map - self.controller - self.model, 0.0)
        return {"step_map_s": self.step_map, "controller_s": self.controller, "model_s": self.model,
                "search_s": search}


def footholds_to_fly(success: bool, footholds, safe_footholds, k: int | None = None):
    """The footholds a loop flies before it plans again, at most ``k`` (None: no limit): a plan's, or, where it found
    no sequence to the target, its safe hops' but the last (the hop known to exist after them) when there are two or
    more; none without either. Takes a Plan's arrays or its record's lists (``Plan.summary``)."""
    if success or safe_footholds is None or len(safe_footholds) == 0:
        return footholds[:k] if success else footholds[:0]
    n = max(len(safe_footholds) - 1, 1)
    return safe_footholds[:n if k is None else min(k, n)]


@dataclass
class Plan:
    """The result of ``planner.plan``: ``success`` with the best sequence in ``footholds``/``leg_angles``/
    ``apexes`` (and up to d ``alternatives`` for the search planners), or ``success=False`` and a
    ``message`` saying why no plan was found. ``target_x`` is what the plan aimed to pass: the goal, or the
    edge of the perception window when the goal lies beyond it. ``ode_calls`` counts step-map evaluations.
    ``time_limited``: the wall-clock safety limit stopped the planner (a result that depends on the machine).
    ``timing``: where ``time_s`` went (``Timing.record``), for the planners that account for it. On a height map
    ``target_y`` is the target's y, and a sequence holds footholds (x, y, z), leg angles (pitch, roll) and apexes
    (x, y, z, xdot, ydot). ``safe_hops``:
    where no sequence reaches the target, the hops that keep the hopper alive longest and best placed to plan again
    (the deepest branch its searches grew, for the planners asked for it), None where there are none; a plan with
    them is still ``success=False``, and its message says it holds them."""

    planner: str
    success: bool
    target_x: float
    ode_calls: int = 0
    time_s: float = 0.0
    nodes_expanded: int = 0
    message: str = ""
    sequences: list = field(default_factory=list)
    time_limited: bool = False
    timing: dict | None = None
    safe_hops: FootstepSequence | None = None
    target_y: float | None = None

    @property
    def best(self) -> FootstepSequence | None:
        return self.sequences[0] if self.sequences else None

    @property
    def footholds(self) -> np.ndarray:
        return self.best.footholds if self.sequences else np.zeros(0)

    @property
    def leg_angles(self) -> np.ndarray:
        return self.best.leg_angles if self.sequences else np.zeros(0)

    @property
    def apexes(self) -> np.ndarray:
        return self.best.apexes if self.sequences else np.zeros((0, 3))

    @property
    def alternatives(self) -> list:
        return self.sequences[1:]

    def to_fly(self, k: int | None = None) -> np.ndarray:
        """The footholds a loop flies before it plans again, at most ``k`` (``footholds_to_fly``)."""
        return footholds_to_fly(self.success, self.footholds, None if self.safe_hops is None else
                                self.safe_hops.footholds, k)

    def summary(self) -> dict:
        """The per-planning-call record the evaluation writes."""
        return {"success": self.success, "message": self.message, "ode_calls": self.ode_calls,
                "t_plan_s": self.time_s, "nodes_expanded": self.nodes_expanded, "target_x": self.target_x,
                "footholds": self.footholds.tolist(), "time_limited": self.time_limited,
                **({"target_y": self.target_y} if self.target_y is not None else {}),
                **({"timing": self.timing} if self.timing is not None else {}),
                **({"safe_footholds": self.safe_hops.footholds.tolist()} if self.safe_hops is not None else {})}


# The most node expansions a search may be given: the search sizes an array by it before it starts, and at 1-2 ms a
# node 10 million are hours of search, far beyond any budget a plan uses (the default 1,000, the docs' 10x 10,000,
# the model checker's 600,000 per case). A larger budget is a typo, not a search.
MAX_NODES = 10_000_000
# The most step-map calls: an expansion calls the step map once per leg angle of its fan (41 on the nominal grid,
# ``planners.search.tree.REACH_ANGLES``), so MAX_NODES expansions make fewer than this; the compiled search holds
# the limit in a 64-bit integer, which a larger Python int overflows.
MAX_ODE_CALLS = 100 * MAX_NODES


@dataclass(frozen=True)
class Budget:
    """Termination conditions. A search attempt stops after ``max_nodes`` node expansions or ``max_ode_calls``
    step-map calls (None: no such limit): deterministic budgets, so a plan, its nodes and its ODE calls are the
    same on any machine. ``max_time_s`` is a safety limit on the wall-clock time of the whole call, reported in
    ``Plan.time_limited`` when it binds. The default node budget lets a Step-space call that finds no plan search
    for about as long as the paper's 2 s budget did (1-2 ms a node on one core)."""

    max_nodes: int = 1000
    max_ode_calls: int | None = None
    max_time_s: float = 60.0

    def __post_init__(self):
        object.__setattr__(self, "max_nodes", check_count(self.max_nodes, "max_nodes", high=MAX_NODES))
        if self.max_ode_calls is not None:
            object.__setattr__(self, "max_ode_calls",
                               check_count(self.max_ode_calls, "max_ode_calls", high=MAX_ODE_CALLS))
        object.__setattr__(self, "max_time_s", check_number(self.max_time_s, "max_time_s (seconds)", positive=True))


@dataclass(frozen=True)
class Problem:
    """One planning query after its inputs were checked: the window the footholds must stay in, the target."""

    apex: ApexState
    terrain: Terrain
    goal_x: float
    params: SlipParams
    units: HopperUnits  # the hopper's units: what turns a setting tuned for the paper's hopper into this one's
    window_end: float   # footholds must lie before this x: the horizon, or where the terrain's knowledge ends
    target_x: float     # a sequence is complete when a foothold passes this x
    deadline: float     # time.perf_counter() value at which the planner must stop
    timing: Timing = field(default_factory=Timing)  # where the call's time goes, filled in as it runs
    # the hop that reached ``apex`` as a template's learned correction takes it (``drakeslip.apex_correction``):
    # (apex height above its foothold, speed, foothold ahead, 1), zeros where it is not known
    before: np.ndarray = field(default_factory=lambda: np.zeros(4))


class Planner(ABC):
    """Base class: ``plan(apex, terrain, goal, params) -> Plan``. Subclasses implement ``_plan`` (and ``plan_on_map``
    where they plan on height maps too).

    A planner plans for the hopper ``params`` it is given (default: the paper's). Every setting that depends on the
    hopper is the paper's value in the hopper's units (``drakeslip.units.HopperUnits``: lengths times its length
    factor, speeds times its speed factor), so a planner does the same for every hopper and, for the paper's,
    exactly what its settings say. Options left at None take these values; an option given is in SI units and is
    used as it is, for any hopper. ``horizon``: how far ahead of the body footholds may lie (default the paper's
    perception window, 8 m, in the hopper's lengths); the plan aims ``TARGET_MARGIN`` (1 m in the hopper's lengths)
    short of it when the goal lies beyond."""

    name = "planner"

    def __init__(self, max_nodes: int = Budget.max_nodes, max_ode_calls: int | None = Budget.max_ode_calls,
                 max_time_s: float = Budget.max_time_s, horizon: float | None = None):
        self.budget = Budget(max_nodes, max_ode_calls, max_time_s)
        self.horizon = None if horizon is None else check_number(horizon, "horizon", positive=True, bound=HORIZON)

    def plan(self, apex, terrain, goal, params: SlipParams | None = None, before=None) -> Plan:
        """Plan from ``apex`` over ``terrain`` to ``goal`` for the hopper ``params``. On a profile (a ``Terrain``) the
        apex is (x, z, xdot) and the goal an x; ``before``: the hop that reached ``apex``, (x, z, xdot) of the apex it
        started from and its foothold x, which a robot's template with a learned correction predicts the next hop
        from (None: not known). On a height map (``drakeslip.spatial.heightmap.HeightMap``) the apex is (x, y, z,
        xdot, ydot) and the goal a point (x, y): ``plan_on_map``."""
        if isinstance(terrain, HeightMap):
            if before is not None:
                raise ValueError("before (the hop that reached the apex) is taken on a profile only")
            return self.plan_on_map(apex, terrain, goal, params)
        t0 = time.perf_counter()
        problem = self.problem(apex, terrain, goal, params, t0, before)
        if problem.apex.x >= problem.goal_x:
            return Plan(self.name, True, problem.target_x, message="already past the goal",
                        sequences=[FootstepSequence(np.zeros(0), np.zeros(0), np.zeros((0, 3)))])
        plan = self._plan(problem)
        plan.time_s = time.perf_counter() - t0
        if problem.timing.accounted:
            problem.timing.total = plan.time_s
            plan.timing = problem.timing.record()
        return plan

    def problem(self, apex, terrain, goal_x, params, t0: float, before=None) -> Problem:
        params = SlipParams() if params is None else params
        apex = check_apex(apex, terrain, params)
        rim = terrain.far_rim(apex.x)
        if rim is not None and apex.z <= rim[1]:
            raise ValueError(f"apex (x={apex.x}, z={apex.z}) is inside a ditch: its far side at x={rim[0]:g} rises to "
                             f"{rim[1]:g} m, above the body")
        if apex.xdot <= 0:
            raise ValueError(f"apex xdot={apex.xdot} must be positive: the planners hop forward")
        goal_x = check_number(goal_x, "goal_x", bound=POSITION)
        units = units_of(params)
        horizon, margin = units.length_or(self.horizon, WINDOW_AHEAD), TARGET_MARGIN * units.length
        if horizon <= margin:
            raise ValueError(f"horizon must be a distance above the target margin, {margin:g} m for this hopper, "
                             f"got {horizon!r}")
        # a map extends flat past its last cell; a perception window ends where the robot's knowledge does
        window_end = min(apex.x + horizon, terrain.known_end)
        target_x = min(goal_x, window_end - margin)
        return Problem(apex, terrain, goal_x, params, units, window_end, target_x, t0 + self.budget.max_time_s,
                       before=before_features(before, terrain))

    @abstractmethod
    def _plan(self, problem: Problem) -> Plan:
        ...

    def plan_on_map(self, apex, height_map, goal, params: SlipParams | None = None) -> Plan:
        """The plan on a height map; a planner that plans on profiles only says so."""
        raise ValueError(f"the {self.name!r} planner plans on profiles (Terrain) only, not on a height map")

    @classmethod
    def files_read(cls, options: dict) -> dict:
        """The files a planner built with ``options`` reads (its weights), by option name: every option, given or
        left at its default, whose value names an existing file."""
        files = {}
        for name, parameter in inspect.signature(cls).parameters.items():
            value = options.get(name, parameter.default)
            if isinstance(value, (str, Path)) and Path(value).is_file():
                files[name] = str(value)
        return files


def before_features(before, terrain: Terrain) -> np.ndarray:
    """``Problem.before`` for the hop ``before`` ((x, z, xdot, foothold x), None: not known) on ``terrain``."""
    if before is None:
        return np.zeros(4)
    if len(before) != 4:
        raise ValueError(f"before must be (x, z, xdot, foothold x) of the hop that reached the apex, got {before!r}")
    x, z, xdot, foothold = (check_number(v, f"before[{i}]", bound=POSITION) for i, v in enumerate(before))
    return np.array([z - float(terrain.height_at(foothold)), xdot, foothold - x, 1.0])
