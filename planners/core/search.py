"""The compiled best-first search (Algorithm 1 of the paper, as ``planners.search.tree.best_first`` runs it in
Python) and what the planners call: ``grid_search`` for Step-space's grid."""
from __future__ import annotations

import functools
import math

import numpy as np

from drakeslip.compiled import compiled
from planners.base import Problem
from planners.core.clock import N_SLOTS
from planners.core.grid import expand_grid
from planners.core.sampled import sampled_best_first
from planners.core.robust import FAILED_CHECK, pop_admitted, robust_arrays, root_flights
from planners.core.tree import CAPACITY, EXHAUSTED, GO_ON, GOALS, NO_LIMIT, add_children, budget_stop, new_tree
from planners.search.tree import FRICTION_MARGIN, REACH_ANGLES, REEXPAND_PENALTY, SearchResult, SearchTree

STOPS = ("goals", "exhausted", "nodes", "ode_calls", "time")  # by the stop codes of planners/core/tree.py


@compiled()
def grid_best_first(root, terr, p, net, sin_a, cos_a, s, rob, target_x, weights, n_sequences, max_nodes,
                    max_ode_calls, deadline):
    """``best_first`` with Step-space's grid expansion (``expand_grid``, settings ``s``). Returns (tree, its size,
    goals, expanded nodes, step-map calls, expansions, stop code, time slots)."""
    tree = new_tree(root[0], root[1], root[2])
    # the counters are int64 from the start: a literal 0 passed on to a compiled function compiles a second copy of it
    size, node, heap = np.int64(1), np.int64(0), np.int64(0)
    keys, ids = np.empty(CAPACITY), np.empty(CAPACITY, np.int64)
    goals, expanded = np.empty(n_sequences, np.int64), np.empty(max_nodes, np.int64)
    n_goals = ode_calls = expansions = n_expanded = np.int64(0)  # expansions also count nodes that failed the check
    slots = np.zeros(N_SLOTS)
    flights = root_flights(rob)
    stop = EXHAUSTED
    while True:
        spent = budget_stop(expansions, max_nodes, ode_calls, max_ode_calls, deadline)
        if spent != GO_ON:
            stop = spent
            break
        if node != FAILED_CHECK:
            a = tree[3][node]
            angles, footholds, apexes, d, calls, beyond = expand_grid(a[0], a[1], a[2], terr, p, net, sin_a, cos_a, s,
                                                                      slots)
            expanded[n_expanded] = node
            n_expanded += 1
            expansions += 1
            ode_calls += calls
            if beyond and node > 0:
                goals[n_goals] = node
                n_goals += 1
                if n_goals >= n_sequences:
                    stop = GOALS
                    break
            tree, size, keys, ids, heap = add_children(tree, size, node, angles, footholds, apexes, d, target_x,
                                                       weights, keys, ids, heap)
        node, heap, n_goals, hops, flights = pop_admitted(tree, keys, ids, heap, goals, n_goals, target_x, rob,
                                                          flights, terr, net, slots)
        ode_calls += hops
        if node == FAILED_CHECK:  # closed: counts as an expansion with no children
            expansions += 1
        if n_goals >= n_sequences:
            stop = GOALS
            break
        if node == -1:
            break
    return tree, size, goals[:n_goals], expanded[:n_expanded], ode_calls, expansions, stop, slots


def terrain_arrays(terrain) -> tuple:
    """(heights, x0, cell, ditch height, lowest solid height) of ``terrain`` for the core."""
    solid = terrain.heights[terrain.heights > terrain.ditch_height]
    lowest = float((solid if solid.size else terrain.heights).min())
    return terrain.heights, float(terrain.x0), float(terrain.cell), float(terrain.ditch_height), lowest


@functools.lru_cache(maxsize=64)
def reach_angles(params) -> tuple:
    """Sines and cosines of the reach angles of ``touchdown_range`` for the hopper ``params`` (computed once per
    hopper; read-only)."""
    angles = REACH_ANGLES * FRICTION_MARGIN * math.atan(params.friction)
    return np.sin(angles), np.cos(angles)


def cost_weights(weights, units) -> tuple:
    """(progress, speed, isolation) weights of a node's cost for a hopper of ``units``."""
    return float(weights.progress), float(weights.speed * units.time), float(weights.isolation)


def tree_of(root_apex, tree, size, goals, expanded) -> SearchTree:
    """The Python ``SearchTree`` of a compiled search's arrays."""
    parent, angle, foothold, apex, cost, depth = (a[:size] for a in tree)
    return SearchTree(tuple(root_apex), parent.tolist(), angle.tolist(), foothold.tolist(),
                      list(map(tuple, apex.tolist())), cost.tolist(), depth.tolist(), goals.tolist(),
                      expanded.tolist())


def grid_search(problem: Problem, settings: np.ndarray, robustness, controller, weights, n_sequences: int, budget,
                timing) -> SearchResult:
    """One Step-space search on the compiled core (``StepSpacePlanner`` builds ``settings``), its popped nodes checked
    by ``robustness`` (a ``Robustness``, or None); adds its time to ``timing`` (``planners.base.Timing``)."""
    sin_a, cos_a = reach_angles(problem.params)
    result = grid_best_first(np.array(problem.apex, dtype=np.float64), terrain_arrays(problem.terrain),
                             problem.params.as_array(), controller.arrays().astuple(), sin_a, cos_a, settings,
                             robust_arrays(robustness, problem), float(problem.target_x),
                             cost_weights(weights, problem.units), int(n_sequences),
                             int(budget.max_nodes), NO_LIMIT if budget.max_ode_calls is None else budget.max_ode_calls,
                             float(problem.deadline))
    tree, size, goals, expanded, ode_calls, expansions, stop, slots = result
    timing.add(slots)
    return SearchResult(tree_of(problem.apex, tree, size, goals, expanded), int(ode_calls), int(expansions),
                        STOPS[stop])


def sampled_search(problem: Problem, settings: np.ndarray, window: np.ndarray, model, rng, width: int, robustness,
                   controller, weights, n_sequences: int, budget, timing) -> SearchResult:
    """One LSTM-guided search on the compiled core (``LSTMGuidedPlanner`` builds ``settings`` and ``window``;
    ``model``: ``planners.core.model.ModelArrays``), its popped nodes checked by ``robustness`` (or None); adds its
    time to ``timing``."""
    sin_a, cos_a = reach_angles(problem.params)
    result = sampled_best_first(np.array(problem.apex, dtype=np.float64), terrain_arrays(problem.terrain),
                                problem.params.as_array(), controller.arrays().astuple(), sin_a, cos_a, settings,
                                window, model.astuple(), rng, int(width), robust_arrays(robustness, problem),
                                float(problem.target_x),
                                cost_weights(weights, problem.units), REEXPAND_PENALTY * problem.units.length,
                                int(n_sequences), int(budget.max_nodes),
                                NO_LIMIT if budget.max_ode_calls is None else budget.max_ode_calls,
                                float(problem.deadline))
    tree, size, goals, expanded, ode_calls, expansions, stop, slots = result
    timing.add(slots)
    return SearchResult(tree_of(problem.apex, tree, size, goals, expanded), int(ode_calls), int(expansions),
                        STOPS[stop])
