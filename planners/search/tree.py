"""Best-first search over footstep trees (Algorithm 1 of the paper), shared by the search planners. A planner
supplies the children of a node; this module grows the tree, scores the children and pops the cheapest node
until d nodes pass the target or a budget runs out.
"""
from __future__ import annotations

import functools
import heapq
import time
from dataclasses import dataclass, field

import numpy as np

from drakeslip import Terrain, step_batch
from drakeslip.compiled import compiling

from planners.base import Budget, FootstepSequence, Plan, Planner, Problem

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


@dataclass(frozen=True)
class CostWeights:
    """h = progress * |x - target| + speed * T * |xdot| + isolation * D (the paper's w1, w2, w3), in metres of
    progress: T is the hopper's time factor (``HopperUnits.time``, 1 s for the paper's hopper), so the speed term
    weighs the same for every hopper."""

    progress: float = 1.0
    speed: float = 1.0
    isolation: float = 2.0


@dataclass
class Children:
    """The successful children of one expansion, as arrays (k = how many)."""

    angles: np.ndarray      # (k,) leg angles
    footholds: np.ndarray   # (k,) the footholds the plan records (touchdown, or the desired x_L)
    apexes: np.ndarray      # (k, 3) predicted next apex
    isolation: np.ndarray   # (k,) D, the spread to the nearest sibling footholds
    ode_calls: int
    beyond: bool = False    # a successful hop from this node lands past the perception window
    more: bool = False      # the node has candidates left untried: expand it again if the search comes back


@dataclass
class SearchTree:
    """Every node the search created. Node 0 is the root (the start apex, no foothold). For node i > 0:
    ``parent[i]``, the leg ``angle[i]`` applied at the parent's apex, the ``foothold[i]`` it lands on and the
    ``apex[i]`` it reaches. ``goals`` are the nodes that passed the target, in the order they were popped.
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

    def add(self, parent: int, children: Children, cost: np.ndarray) -> range:
        first = len(self.parent)
        k = children.angles.size
        self.parent.extend([parent] * k)
        self.angle.extend(children.angles.tolist())
        self.foothold.extend(children.footholds.tolist())
        self.apex.extend(map(tuple, children.apexes.tolist()))
        self.cost.extend(cost.tolist())
        self.depth.extend([self.depth[parent] + 1] * k)
        return range(first, first + k)

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
                                np.array([self.apex[i] for i in nodes]).reshape(-1, 3))

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


def isolation(footholds: np.ndarray, ok: np.ndarray, at_failure: float = ISOLATION_AT_FAILURE) -> np.ndarray:
    """D for each successful sample: the mean spread to its nearest successful siblings on either side, the
    samples taken in the order they were generated (increasing angle or desired foothold). A neighbour sample
    that failed with no success beyond it counts ``at_failure`` (ISOLATION_AT_FAILURE in the hopper's lengths);
    at the end of the sampled range the spread to the one existing neighbour counts twice."""
    idx = np.flatnonzero(ok)
    x = footholds[idx]
    n = footholds.size
    if idx.size == 0:
        return np.zeros(0)
    left = np.full(idx.size, np.nan)
    right = np.full(idx.size, np.nan)
    left[1:] = np.abs(x[1:] - x[:-1])
    right[:-1] = left[1:]
    # no successful sibling on a side: a failure boundary if a failed sample lies there, else the range end
    left[0] = at_failure if idx[0] > 0 else np.nan
    right[-1] = at_failure if idx[-1] < n - 1 else np.nan
    left = np.where(np.isnan(left), right, left)
    right = np.where(np.isnan(right), left, right)
    d = 0.5 * (left + right)
    return np.where(np.isnan(d), at_failure, d)


@dataclass
class SearchResult:
    tree: SearchTree
    ode_calls: int
    nodes_expanded: int
    stop: str   # "goals", "exhausted" (queue empty), "nodes" or "ode_calls" (budget), "time" (safety limit)


def best_first(problem: Problem, expand, cost_weights: CostWeights, n_sequences: int, budget: Budget,
               admit=None) -> SearchResult:
    """Algorithm 1: expand the cheapest node, add its successful children, pop the next cheapest; a popped
    node whose foothold passes the target is a goal. So is an expanded node with a successful hop past the
    window's far edge: its sequence goes as far as the robot can see (at speed, one stride can jump the whole
    band between the target and the edge). Stops at ``n_sequences`` goals, an empty queue, the ``budget``'s
    node expansions or step-map calls, or the problem's deadline (the safety limit). ``expand(tree, node) ->
    Children``.

    ``admit(tree, node) -> (passed, step-map calls)``, if given, checks each popped node before it can be a goal
    or be expanded (a lazy check: only the nodes the search gets to are checked); a node that fails is closed,
    and counts as an expansion with no children."""
    tree = SearchTree(tuple(problem.apex))
    w, units = cost_weights, problem.units
    speed_weight, reexpand = w.speed * units.time, REEXPAND_PENALTY * units.length
    queue: list = []
    ode_calls = expansions = 0
    node = 0  # the node to expand next; None after a popped node failed ``admit``
    stop = "exhausted"
    while True:
        if expansions >= budget.max_nodes:
            stop = "nodes"
            break
        if budget.max_ode_calls is not None and ode_calls >= budget.max_ode_calls:
            stop = "ode_calls"
            break
        if time.perf_counter() >= problem.deadline:
            stop = "time"
            break
        if node is not None:
            children = expand(tree, node)
            expansions += 1
            tree.expanded.append(node)
            ode_calls += children.ode_calls
            if children.beyond and node > 0:
                tree.goals.append(node)
                if len(tree.goals) >= n_sequences:
                    stop = "goals"
                    break
            if children.angles.size:
                cost = (w.progress * np.abs(children.footholds - problem.target_x)
                        + speed_weight * np.abs(children.apexes[:, 2]) + w.isolation * children.isolation)
                for i, c in zip(tree.add(node, children, cost), cost.tolist()):
                    heapq.heappush(queue, (c, i))
            if children.more:  # back in the queue behind its own children (the root: behind everything)
                heapq.heappush(queue, (tree.cost[node] + reexpand, node))
        node = -1
        while queue:
            _, i = heapq.heappop(queue)
            if admit is not None:
                passed, calls = admit(tree, i)
                ode_calls += calls
                if not passed:
                    expansions += 1
                    node = None
                    break
            if tree.foothold[i] >= problem.target_x:
                tree.goals.append(i)
                if len(tree.goals) >= n_sequences:
                    break
                continue
            node = i
            break
        if len(tree.goals) >= n_sequences:
            stop = "goals"
            break
        if node == -1:
            break
    return SearchResult(tree, ode_calls, expansions, stop)


def run_attempts(planner: Planner, problem: Problem, attempts) -> Plan:
    """Run searches (label, thunk) in order until one finds a sequence; sum their work into one Plan. The safety
    time limit ends the call (``Plan.time_limited``)."""
    ode_calls = nodes = 0
    stops = []
    for label, attempt in attempts:
        result = attempt()
        ode_calls += result.ode_calls
        nodes += result.nodes_expanded
        stops.append(f"{label}: {result.stop}")
        if result.tree.goals:
            before = f" (after {'; '.join(stops[:-1])})" if len(stops) > 1 else ""
            return Plan(planner.name, True, problem.target_x, ode_calls, nodes_expanded=nodes,
                        sequences=[result.tree.path(g) for g in result.tree.goals],
                        time_limited=result.stop == "time", message=f"found by {label}{before}")
        if result.stop == "time":
            break
    return Plan(planner.name, False, problem.target_x, ode_calls, nodes_expanded=nodes,
                message=f"no plan found to x={problem.target_x:.2f} ({'; '.join(stops)})",
                time_limited=stops[-1].endswith(": time"))


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
