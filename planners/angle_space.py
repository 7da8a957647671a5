"""The Angle-space planner: best-first search whose children are sampled leg angles (paper, Algorithm 1)."""
from __future__ import annotations

import math
import time

import numpy as np

from drakeslip import step_batch

from .base import Plan, Planner, Problem
from .registry import register
from .search import Children, CostWeights, SearchResult, best_first, clear_of_edges, isolation, warm_up

FRICTION_MARGIN = 0.99  # sample strictly inside the friction cone |theta| < atan(mu)
# Beyond the paper: a child whose next apex is slower than this is dropped. Near-zero apex speeds are one
# small leg-angle error away from a stall, and the speed term of the cost would otherwise favour them.
MIN_SPEED = 0.3
# Beyond the paper: footholds closer than this to a step or ditch edge are dropped; the controller lands
# within a few millimetres of a foothold, so 2 cm keeps every executed step on the surface it was planned on.
EDGE_MARGIN = 0.02


@register("angle")
class AngleSpacePlanner(Planner):
    """Each expansion draws ``branching`` leg angles in the friction cone, one uniformly in each of
    ``branching`` equal strata (seeded), and simulates them all with one batched fast step-map call. If a
    search finds no sequence it is retried with each of ``fallback`` branching factors (the paper: 20, then
    30). Returns up to ``n_sequences`` sequences (d). Beyond the paper, children slower than ``min_speed`` at
    their next apex or landing within ``edge_margin`` of an edge are dropped (see MIN_SPEED, EDGE_MARGIN)."""

    def __init__(self, branching: int = 20, fallback: tuple = (30,), n_sequences: int = 1,
                 weights: CostWeights | tuple = CostWeights(), min_speed: float = MIN_SPEED,
                 edge_margin: float = EDGE_MARGIN, seed: int = 0, **budget):
        super().__init__(**budget)
        for b in (branching, *fallback):
            if not (isinstance(b, int) and b >= 1):
                raise ValueError(f"branching factors must be positive integers, got {b!r}")
        if not (isinstance(n_sequences, int) and n_sequences >= 1):
            raise ValueError(f"n_sequences must be a positive integer, got {n_sequences!r}")
        self.branchings = (branching, *fallback)
        self.n_sequences = n_sequences
        self.weights = weights if isinstance(weights, CostWeights) else CostWeights(*weights)
        warm_up()
        self.min_speed = float(min_speed)
        self.edge_margin = float(edge_margin)
        self.seed = seed

    def search(self, apex, terrain, goal_x, params=None, branching: int | None = None) -> SearchResult:
        """One search with one branching factor; the tree in the result holds every node it created."""
        problem = self.problem(apex, terrain, goal_x, params, time.perf_counter())
        return self._search(problem, branching or self.branchings[0])

    def _search(self, problem: Problem, branching: int) -> SearchResult:
        rng = np.random.default_rng(self.seed)
        limit = FRICTION_MARGIN * math.atan(problem.params.friction)
        edges = np.linspace(-limit, limit, branching + 1)
        params, terrain, window_end = problem.params, problem.terrain, problem.window_end

        def expand(tree, node) -> Children:
            angles = edges[:-1] + rng.uniform(0.0, 1.0, branching) * np.diff(edges)
            res = step_batch(tree.apex[node], angles, terrain, params)
            ok = res.ok & (res.next_xdot >= self.min_speed)
            ok[ok] &= clear_of_edges(terrain, res.touchdown_x[ok], self.edge_margin)
            inside = res.touchdown_x < window_end  # hops past the window end the sequence, they are not in it
            d = isolation(res.touchdown_x, ok)[inside[ok]]
            beyond = bool(np.any(ok & ~inside))
            ok &= inside
            apexes = np.stack([res.next_x, res.next_z, res.next_xdot], axis=1)[ok]
            return Children(angles[ok], res.touchdown_x[ok], apexes, d, branching, beyond)

        return best_first(problem, expand, self.weights, self.n_sequences, self.budget.max_nodes)

    def _plan(self, problem: Problem) -> Plan:
        return run_attempts(self, problem, [(f"B={b}", lambda b=b: self._search(problem, b)) for b in self.branchings])


def run_attempts(planner: Planner, problem: Problem, attempts) -> Plan:
    """Run searches (label, thunk) in order until one finds a sequence; sum their work into one Plan."""
    ode_calls = nodes = 0
    stops = []
    for label, attempt in attempts:
        result = attempt()
        ode_calls += result.ode_calls
        nodes += result.nodes_expanded
        stops.append(f"{label}: {result.stop}")
        if result.tree.goals:
            return Plan(planner.name, True, problem.target_x, ode_calls, nodes_expanded=nodes,
                        sequences=[result.tree.path(g) for g in result.tree.goals])
        if result.stop == "time":
            break
    return Plan(planner.name, False, problem.target_x, ode_calls, nodes_expanded=nodes,
                message=f"no plan found to x={problem.target_x:.2f} ({'; '.join(stops)})")
