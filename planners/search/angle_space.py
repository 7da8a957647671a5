"""The Angle-space planner: best-first search whose children are sampled leg angles (paper, Algorithm 1)."""
from __future__ import annotations

import math
import time

import numpy as np

from drakeslip import step_batch
from drakeslip.params import check_count, shown

from planners.base import Plan, Planner, Problem
from planners.core.grid import isolation
from planners.core.tree import NO_GOAL, Children, child_costs
from planners.search.loop import ADMIT_ALL, search
from planners.search.tree import (EDGE_MARGIN, FRICTION_MARGIN, ISOLATION_AT_FAILURE, MIN_SPEED, Attempts,
                                  CostWeights, SearchResult, check_options, check_weights, clear_of_edges, warm_up)


class AngleSpacePlanner(Planner):
    """Each expansion draws ``branching`` leg angles in the friction cone, one uniformly in each of
    ``branching`` equal strata (seeded), and simulates them all with one batched fast step-map call. If a
    search finds no sequence it is retried with each of ``fallback`` branching factors (the paper: 20, then
    30). Returns up to ``n_sequences`` sequences (d). Children slower than ``min_speed`` at their next apex or
    landing within ``edge_margin`` of an edge are dropped (see MIN_SPEED, EDGE_MARGIN; left at None, the paper's
    values in the hopper's units, given, in m/s and m)."""

    name = "angle"

    def __init__(self, branching: int = 20, fallback: tuple = (30,), n_sequences: int = 1,
                 cost_weights: CostWeights | tuple = CostWeights(), min_speed: float | None = None,
                 edge_margin: float | None = None, seed: int = 0, **budget):
        super().__init__(**budget)
        if not isinstance(fallback, (tuple, list)):
            raise ValueError(f"fallback must be a list of branching factors, got {shown(fallback)}")
        self.branchings = tuple(check_count(b, "branching factor") for b in (branching, *fallback))
        self.n_sequences = check_count(n_sequences, "n_sequences")
        self.cost_weights = check_weights(cost_weights)
        self.min_speed, self.edge_margin = check_options(min_speed, edge_margin)
        self.seed = check_count(seed, "seed", low=0)
        warm_up()

    def search(self, apex, terrain, goal_x, params=None, branching: int | None = None) -> SearchResult:
        """One search with one branching factor; the tree in the result holds every node it created."""
        problem = self.problem(apex, terrain, goal_x, params, time.perf_counter())
        return self._search(problem, branching or self.branchings[0])

    def _search(self, problem: Problem, branching: int) -> SearchResult:
        return search(problem, AngleExpansion(self, problem, branching), ADMIT_ALL, self.n_sequences, self.budget)

    def _plan(self, problem: Problem) -> Plan:
        tried = Attempts(self.name, problem.target_x)
        for b in self.branchings:
            if tried.ended(f"B={b}", self._search(problem, b)):
                break
        return tried.plan()



class AngleExpansion:
    """Angle-space's expansion (run as Python): ``branching`` leg angles in the friction cone, one uniformly in
    each of ``branching`` equal strata, simulated with one batched fast step-map call."""

    def __init__(self, planner: AngleSpacePlanner, problem: Problem, branching: int):
        self.problem, self.branching = problem, branching
        self.rng = np.random.default_rng(planner.seed)
        limit = FRICTION_MARGIN * math.atan(problem.params.friction)
        self.edges = np.linspace(-limit, limit, branching + 1)
        units = problem.units
        self.min_speed = units.speed_or(planner.min_speed, MIN_SPEED)
        self.edge_margin = units.length_or(planner.edge_margin, EDGE_MARGIN)
        self.at_failure = ISOLATION_AT_FAILURE * units.length
        self.scoring = planner.cost_weights.scoring(problem)

    def expand(self, state, tree, size, node, slots):
        """(the node's children, the state: none, this expansion keeps its own)."""
        problem, edges = self.problem, self.edges
        angles = edges[:-1] + self.rng.uniform(0.0, 1.0, self.branching) * np.diff(edges)
        res = step_batch(tuple(map(float, tree.apex[node])), angles, problem.terrain, problem.params)
        ok = res.ok & (res.next_xdot >= self.min_speed)
        ok[ok] &= clear_of_edges(problem.terrain, res.touchdown_x[ok], self.edge_margin)
        inside = res.touchdown_x < problem.window_end  # hops past the window end the sequence, they are not in it
        d = isolation(res.touchdown_x, ok, self.at_failure)[inside[ok]]
        beyond = bool(np.any(ok & ~inside))
        ok &= inside
        apexes = np.stack([res.next_x, res.next_z, res.next_xdot], axis=1)[ok]
        footholds = res.touchdown_x[ok]
        return Children(angles[ok], footholds, apexes, child_costs(footholds, apexes, d, self.scoring),
                        self.branching, beyond, False, NO_GOAL), state
