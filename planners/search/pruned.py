"""The planners' last stage: Step-space's expansion searched the way the oracle searches (verification/model_check.py),
from a start where the planner's own searches found no sequence.

The nominal best-first search ranks nodes by progress, speed and isolation and stops after its node budget: enough
wherever a plan is easy to find. A start with little energy before high steps can still have a plan that this order
does not reach in time: a run of slow, high hops (often 20 or more) that the speed term ranks last. This stage
searches on from the start with the oracle's pruning:

* the energy graph (``planners.search.energy_graph``): an apex whose next touchdown cannot be on a cell from which
  the target can be reached at all is dropped, and a start from which the graph has no path at all is refused
  without a search ("unreachable"). Both are sound: no plan is lost;
* merged apexes: the SLIP is conservative, so an apex is (x, xdot), and apexes in one cell of ``MERGE_X`` by
  ``MERGE_XDOT`` are expanded once, from the first arrival with the least risk;
* progress minus risk: the node farthest ahead is popped first, less ``RISK_COST`` per slow hop on its path (one to an
  apex slower than the planner's minimum speed; the stage keeps apexes down to ``MIN_SPEED``): low-energy starts need
  slow hops to climb, which a queue of the fast apexes first reaches only after many more nodes;

up to ``max_nodes`` expansions (the planners' ``pruned_nodes`` option, ``MAX_NODES`` by default) or the planning call's
deadline. The children are Step-space's (``planners.core.grid.expand_grid``: grid footholds aimed by the controller
and flown by the step map, away from edges, landing within the tolerance), so a plan found here is one the controller
hits, as every other plan is. Lengths and speeds are the paper's hopper's, used in the hopper's units.
"""
from __future__ import annotations

import numpy as np

from drakeslip.compiled import compiling

from planners.base import Problem
from planners.search.energy_graph import CellGraph, Coreach, GraphTooLarge
from planners.search.tree import SearchResult, SearchTree

# Node budget of the stage: about a second on one core (0.2 ms a node: some 20 candidates aimed and flown). The
# plans the nominal search misses on the committed and freshly drawn suites took it under 200 nodes; the oracle,
# on its finer angle grid, needs up to some 10^5 on the hardest starts, so a larger budget can still find more.
MAX_NODES = 5_000
MERGE_X, MERGE_XDOT = 0.01, 0.01   # [m], [m/s]: the oracle's coarse merge cells
MIN_SPEED = 0.1     # [m/s]: slower apexes are dropped (the oracle's floor)
RISK_COST = 0.3     # [m] of progress the queue takes off per slow hop on a node's path (the oracle's)


def pruned_search(problem: Problem, settings: np.ndarray, controller, max_nodes: int = MAX_NODES) -> SearchResult:
    """The stage from ``problem``'s start, with Step-space's grid ``settings`` (``StepSpacePlanner.core_settings``)
    and ``controller``, on the compiled core (``planners.core.pruned``); stops at the first sequence whose foothold
    passes the target (or whose hop lands past the window), an empty queue ("exhausted"), no path in the energy graph
    ("unreachable"), ``max_nodes`` expansions or the problem's deadline; it is skipped when the energy graph would be
    too large (``energy_graph.MAX_CELLS``). Adds the controller's and the step map's
    time to ``problem.timing``."""
    from planners.core.grid import MIN_SPEED as MIN_SPEED_FIELD   # the compiled core, loaded on first use
    from planners.core.pruned import pruned_best_first
    from planners.core.search import STOPS, reach_angles, terrain_arrays, tree_of

    units, params, terrain = problem.units, problem.params, problem.terrain
    try:
        graph = CellGraph(problem.apex, terrain, problem.target_x, params)
    except GraphTooLarge as error:   # the stage's pruning is the graph: without one it has nothing to add
        return SearchResult(SearchTree(tuple(problem.apex)), 0, 0, f"skipped, {error}")
    if graph.wall() is not None or not np.any(graph.closure(graph.starts) & graph.ends):
        return SearchResult(SearchTree(tuple(problem.apex)), 0, 0, "unreachable")
    coreach = Coreach(graph)
    cells = (coreach.lo, coreach.hi, coreach.top, float(coreach.top.min(initial=np.inf)))
    s = settings.copy()
    careful, s[MIN_SPEED_FIELD] = float(settings[MIN_SPEED_FIELD]), MIN_SPEED * units.speed
    stage = np.array([careful, MERGE_X * units.length, MERGE_XDOT * units.speed, RISK_COST * units.length,
                      graph.reach, graph.g, problem.target_x])
    sin_a, cos_a = reach_angles(params)
    with compiling():   # compiled at its first use in a process: most plans never reach this stage
        tree, size, goals, expanded, ode_calls, expansions, stop, slots = pruned_best_first(
            np.array(problem.apex, dtype=np.float64), terrain_arrays(terrain), params.as_array(),
            controller.arrays().astuple(), sin_a, cos_a, s, stage, cells, int(max_nodes), float(problem.deadline))
    problem.timing.add(slots)
    return SearchResult(tree_of(problem.apex, tree, size, goals, expanded), int(ode_calls), int(expansions),
                        STOPS[stop])
