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

from planners.base import Budget, Problem
from planners.core.grid import GridExpansion
from planners.core.pruned import Coreachable, MergeAdmission, PrunedExpansion, StageSettings
from planners.search.energy_graph import CellGraph, Coreach, GraphTooLarge
from planners.search.loop import search
from planners.search.tree import SearchResult, SearchTree

# Node budget of the stage: about a second on one core (0.2 ms a node: some 20 candidates aimed and flown). The
# plans the nominal search misses on the committed and freshly drawn suites took it under 200 nodes; the oracle,
# on its finer angle grid, needs up to some 10^5 on the hardest starts, so a larger budget can still find more.
MAX_NODES = 5_000
MERGE_X, MERGE_XDOT = 0.01, 0.01   # [m], [m/s]: the oracle's coarse merge cells
MIN_SPEED = 0.1     # [m/s]: slower apexes are dropped (the oracle's floor)
RISK_COST = 0.3     # [m] of progress the queue takes off per slow hop on a node's path (the oracle's)


def pruned_search(problem: Problem, grid: GridExpansion, max_nodes: int = MAX_NODES) -> SearchResult:
    """The stage from ``problem``'s start, expanding with Step-space's ``grid`` expansion (``StepSpacePlanner
    .expansion``), on the one best-first loop (``planners.core.pruned`` plugs in the merge cells and the energy graph);
    stops at the first sequence whose foothold passes the target (or whose hop lands past the window), an empty queue
    ("exhausted"), no path in the energy graph ("unreachable"), ``max_nodes`` expansions or the problem's deadline; it
    is skipped when the energy graph would be too large (``energy_graph.MAX_CELLS``). Adds the controller's and the
    step map's time to ``problem.timing``."""
    units, params, terrain = problem.units, problem.params, problem.terrain
    try:
        graph = CellGraph(problem.apex, terrain, problem.target_x, params)
    except GraphTooLarge as error:   # the stage's pruning is the graph: without one it has nothing to add
        return SearchResult(SearchTree(tuple(problem.apex)), 0, 0, f"skipped, {error}")
    if graph.wall() is not None or not np.any(graph.closure(graph.starts) & graph.ends):
        return SearchResult(SearchTree(tuple(problem.apex)), 0, 0, "unreachable")
    coreach = Coreach(graph)
    cells = Coreachable(coreach.lo, coreach.hi, coreach.top, float(coreach.top.min(initial=np.inf)))
    stage = StageSettings(grid.grid.min_speed, MERGE_X * units.length, MERGE_XDOT * units.speed,
                          RISK_COST * units.length, float(graph.reach), float(graph.g), float(problem.target_x))
    grid = grid._replace(grid=grid.grid._replace(min_speed=MIN_SPEED * units.speed))   # the stage's floor
    with compiling():   # compiled at its first use in a process: most plans never reach this stage
        return search(problem, PrunedExpansion(grid, stage, cells), MergeAdmission(stage), 1,
                      Budget(max_nodes=int(max_nodes)))
