"""Best-first search over footstep trees (Algorithm 1 of the paper), as the search planners run it: the settings
they share, the tree a search returns, and the record of the searches a planning call tries (``Attempts``); a
search itself is ``planners.search.loop.search``."""
from __future__ import annotations

import functools
from dataclasses import dataclass, field, fields

import numpy as np

from drakeslip import Terrain, step_batch
from drakeslip.bounds import LEG_LENGTH, SPEED, Bound
from drakeslip.compiled import compiling
from drakeslip.params import check_number, shown

from planners.base import FootstepSequence, Plan, Problem

# The settings below in metres and m/s are the paper's hopper's; a search uses each in its hopper's units
# (``Problem.units``: lengths times the length factor, speeds times the speed factor), so it does the same for every
# hopper. FRICTION_MARGIN is a fraction of the friction cone, the same for all.
FRICTION_MARGIN = 0.99  # sample strictly inside the friction cone |theta| < atan(mu)
# Fractions of the friction-cone limit at which a flight's reach is evaluated (step_space.touchdown_range)
REACH_ANGLES = np.linspace(-1.0, 1.0, 41)
# A child whose next apex is slower than this [m/s] is dropped: near-zero apex speeds are one small leg-angle
# error away from a stall, and the speed term of the cost would otherwise favour them.
MIN_SPEED = 0.3
# Footholds closer than this [m] to a step or ditch edge are dropped: the controller lands within a few
# millimetres of a foothold, so 2 cm keeps every executed step on the surface it was planned on.
EDGE_MARGIN = 0.02
# Isolation [m] of a child whose neighbour sample (in angle or foothold order) failed and that has no successful
# sibling on that side: the feasible set ends right next to it, so score it like a wide gap.
ISOLATION_AT_FAILURE = 0.5
# A node with untried candidates returns to the queue at its cost plus this, so it is expanded again only
# once its children's subtrees look worse (in cost units: metres of progress).
REEXPAND_PENALTY = 0.5
# Bounds of the search options given in metres or m/s (None, the default, is the paper's value in the hopper's units),
# for every hopper of drakeslip.bounds (a planner is built before it is told its hopper): the landing tolerance
# (positive: a landing must be strictly closer) and the edge margin up to the longest leg, past which one accepts every
# landing and the other drops every foothold; the speed a hop keeps up to the fastest apex.
DISTANCES, SPEEDS = Bound(0.0, LEG_LENGTH.high, "m"), Bound(0.0, SPEED.high, "m/s")
WEIGHTS = Bound(0.0, 1e6)   # node cost weights are relative (the paper's 1, 1, 2): a millionfold leaves others no say


@dataclass(frozen=True)
class CostWeights:
    """h = progress * |x - target| + speed * T * |xdot| + isolation * D (the paper's w1, w2, w3), in metres of
    progress: T is the hopper's time factor (``HopperUnits.time``, 1 s for the paper's hopper), so the speed term
    weighs the same for every hopper."""

    progress: float = 1.0
    speed: float = 1.0
    isolation: float = 2.0

    def scoring(self, problem: Problem):
        """The node cost's weights for ``problem`` (its target, the hopper's time unit), as the search reads them."""
        from planners.core.tree import Scoring   # the compiled core, loaded by the searches: imports stay light

        return Scoring(float(problem.target_x), float(self.progress), float(self.speed * problem.units.time),
                       float(self.isolation))


def check_weights(weights) -> CostWeights:
    """``cost_weights``: a CostWeights or its fields in order (progress, speed, isolation) as a list, each weight in
    WEIGHTS (a NaN one would order the queue at random); else ValueError naming the option and the value."""
    names = [f.name for f in fields(CostWeights)]
    if not isinstance(weights, CostWeights):
        if not isinstance(weights, (tuple, list)) or len(weights) != len(names):
            raise ValueError(f"cost_weights must be a list of {len(names)} weights ({', '.join(names)}), "
                             f"got {shown(weights)}")
        weights = CostWeights(*weights)
    for name in names:
        check_number(getattr(weights, name), f"cost_weights.{name}", bound=WEIGHTS)
    return weights


def check_options(min_speed, edge_margin) -> tuple:
    """(min_speed, edge_margin) as floats inside SPEEDS and DISTANCES, each None left None (the paper's value in the
    hopper's units); else ValueError naming the option and the value."""
    return (None if min_speed is None else check_number(min_speed, "min_speed", bound=SPEEDS),
            None if edge_margin is None else check_number(edge_margin, "edge_margin", bound=DISTANCES))


@dataclass
class SearchTree:
    """Every node the search created. Node 0 is the root (the start apex, no foothold). For node i > 0:
    ``parent[i]``, the leg ``angle[i]`` applied at the parent's apex, the ``foothold[i]`` it lands on and the
    ``apex[i]`` it reaches (on a height map: the leg's (pitch, roll), the foothold's (x, y, z), the apex's
    (x, y, z, xdot, ydot)). ``goals`` are the nodes that passed the target, in the order they were popped.
    Any root-to-leaf path is a dynamically feasible footstep sequence (the dataset generator uses them all).
    """

    root_apex: tuple
    parent: list = field(default_factory=lambda: [-1])
    angle: list = field(default_factory=lambda: [np.nan])
    foothold: list = field(default_factory=lambda: [np.nan])
    apex: list = field(default_factory=list)
    cost: list = field(default_factory=lambda: [np.inf])
    depth: list = field(default_factory=lambda: [0])
    goals: list = field(default_factory=list)
    expanded: list = field(default_factory=list)

    def __post_init__(self):
        if not self.apex:
            self.apex.append(tuple(self.root_apex))

    def __len__(self):
        return len(self.parent)

    def branch(self, node: int) -> list[int]:
        """The nodes from the root's child on the way to ``node`` through ``node`` itself."""
        nodes = []
        while node > 0:
            nodes.append(node)
            node = self.parent[node]
        return nodes[::-1]

    def path(self, node: int) -> FootstepSequence:
        """The sequence from the root to ``node``."""
        nodes = self.branch(node)
        return FootstepSequence(np.array([self.foothold[i] for i in nodes]),
                                np.array([self.angle[i] for i in nodes]),
                                np.array([self.apex[i] for i in nodes]).reshape(-1, len(self.root_apex)))

    def speeds(self) -> np.ndarray:
        """Each node's apex speed: xdot in the plane, |(xdot, ydot)| on a height map."""
        apex = np.asarray(self.apex, dtype=float)
        return apex[:, 2] if apex.shape[1] == 3 else np.hypot(apex[:, 3], apex[:, 4])

    def leaves(self) -> list[int]:
        """Nodes with no children (the frontier and the dead ends), root excluded."""
        has_child = np.zeros(len(self), dtype=bool)
        has_child[self.parent[1:]] = True
        return [i for i in range(1, len(self)) if not has_child[i]]

    def paths(self):
        """Every root-to-leaf sequence."""
        for leaf in self.leaves():
            yield self.path(leaf)


def clear_of_edges(terrain: Terrain, x: np.ndarray, margin: float) -> np.ndarray:
    """True where the terrain is level within ``margin`` of x on both sides (no step or ditch edge nearby; a sensed
    map's noise is not an edge, see ``Terrain.same_level``)."""
    return terrain.same_level(x - margin, x) & terrain.same_level(x + margin, x)


@functools.cache
def warm_up() -> None:
    """Load the compiled step map once per process, so JIT start-up is not charged to a plan's time budget."""
    with compiling():
        step_batch((0.0, 1.0, 1.0), [0.1], Terrain.flat())


@dataclass
class SearchResult:
    tree: SearchTree
    ode_calls: int
    nodes_expanded: int
    stop: str   # one of STOPS, or why the search did not run ("unreachable", "skipped, ...")


STOPS = ("goals", "exhausted", "nodes", "ode_calls", "time")   # by the stop codes of planners/core/tree.py
# Hops of a branch that make it safer than a shorter one: a loop flies at most three of a plan's hops (the paper's
# protocol) and keeps one it knows exists after them. Deeper branches rank by the speed they end with: the template
# keeps its energy, and one that trades speed for height slows toward the least speed its hops may keep.
SAFE_DEPTH = 4


class Attempts:
    """The searches one planning call ran, in turn until one found a sequence or the safety time limit ended the
    call (``Plan.time_limited``), their work summed into one ``Plan``. The planner runs each search and hands its
    result here, so control stays with the planner. With ``safe_hops``, a call that finds no sequence returns the
    safest branch its searches grew (``Plan.safe_hops``): the deepest, up to SAFE_DEPTH hops, the earlier search's
    (the more robust) where two are as deep, then the one ending fastest. On a height map ``target_y`` is the
    target's y."""

    def __init__(self, planner: str, target_x: float, safe_hops: bool = False, target_y: float | None = None):
        self.planner, self.target_x, self.target_y = planner, target_x, target_y
        self.ode_calls = self.nodes = 0
        self.stops = []
        self.found = None   # (label, result) of the search that found sequences
        self.safe_hops = safe_hops
        self.safest = None   # (capped depth, label, tree, node) of the safest branch so far, with ``safe_hops``

    def ended(self, label: str, result: SearchResult) -> bool:
        """Record the search ``label``'s result; True when the call ends: it found a sequence or ran out of time."""
        self.ode_calls += result.ode_calls
        self.nodes += result.nodes_expanded
        self.stops.append(f"{label}: {result.stop}")
        if result.tree.goals:
            self.found = label, result
        elif self.safe_hops:
            self.keep_safest(label, result.tree)
        return bool(result.tree.goals) or result.stop == "time"

    def keep_safest(self, label: str, tree: SearchTree) -> None:
        """Keep ``tree``'s safest branch where it is deeper (capped at SAFE_DEPTH) than the one kept."""
        if len(tree) < 2:
            return
        depth = np.minimum(np.asarray(tree.depth[1:]), SAFE_DEPTH)
        speed = tree.speeds()[1:]
        node = 1 + int(np.lexsort((-speed, -depth))[0])
        if self.safest is None or depth[node - 1] > self.safest[0]:
            self.safest = int(depth[node - 1]), label, tree, node

    def plan(self) -> Plan:
        """The call's plan: the sequences of the search that found some, or why none was found."""
        if self.found is not None:
            (label, result), stops = self.found, self.stops
            before = f" (after {'; '.join(stops[:-1])})" if len(stops) > 1 else ""
            return Plan(self.planner, True, self.target_x, self.ode_calls, nodes_expanded=self.nodes,
                        sequences=[result.tree.path(g) for g in result.tree.goals],
                        time_limited=result.stop == "time", message=f"found by {label}{before}",
                        target_y=self.target_y)
        message = f"no plan found to {self.where(self.target_x, self.target_y)} ({'; '.join(self.stops)})"
        safe = None
        if self.safest is not None:
            _, label, tree, node = self.safest
            safe = tree.path(node)
            last = safe.footholds[-1]
            point = (last, None) if self.target_y is None else (last[0], last[1])
            message += f"; {len(safe)} safe hops to {self.where(*point)} by {label}"
        return Plan(self.planner, False, self.target_x, self.ode_calls, nodes_expanded=self.nodes, message=message,
                    time_limited=self.stops[-1].endswith(": time"), safe_hops=safe, target_y=self.target_y)

    @staticmethod
    def where(x: float, y: float | None) -> str:
        """A point as the messages write it: x=X in the plane, (X, Y) on a height map."""
        return f"x={x:.2f}" if y is None else f"({x:.2f}, {y:.2f})"


def run_depth(mask: np.ndarray) -> np.ndarray:
    """For each True entry, the number of grid steps to the nearest False one (the array's ends count as
    False); 0 where ``mask`` is False."""
    n = mask.size
    left, right = np.zeros(n, dtype=int), np.zeros(n, dtype=int)
    for i in range(n):
        left[i] = left[i - 1] + 1 if mask[i] and i else int(mask[i])
    for i in range(n - 1, -1, -1):
        right[i] = right[i + 1] + 1 if mask[i] and i < n - 1 else int(mask[i])
    return np.minimum(left, right)
