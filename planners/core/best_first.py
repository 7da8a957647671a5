"""The best-first search (Algorithm 1 of the paper), once, for every search planner: compiled for the core's
expansions, run as Python for the planners' Python ones.

Expand a node, add its children to the tree and the frontier, pop the cheapest node, check it (``admit``), and go on
until ``n_sequences`` nodes pass the target, the frontier is empty, or a budget is spent. What a search plugs in:

* how it **starts** (``start(expansion, admission, root) -> (expansion state, admission state)``): what the
  expansion and the admission keep as the search goes (the sampled draws, the robust particles' flights, the pruned
  stage's merge cells);
* the **expansion** (``expand(expansion, state, tree, size, node, slots) -> (Children, state)``): Step-space's grid
  (``planners.core.grid``), the footstep model's samples (``planners.core.sampled``), the pruned last stage's merged
  grid (``planners.core.pruned``), or a Python object with an ``expand`` method (the Drake step map's, Angle-space's);
* the **admission** (``admit(admission, state, tree, node, slots) -> (verdict, step-map calls, state)``): the robust
  levels' particles (``planners.core.robust``, which admits every node at depth 0), the pruned stage's merge cells,
  or a Python object with an ``admit`` method.

``specialized(start, expand, admit)`` is the loop compiled with those three compiled functions in its calls (the same
code, its globals bound to them: one compiled function per pairing, cached like any other, calling them directly);
``planners.core.searches`` makes the core's pairings. ``python_best_first`` is the loop as Python, calling the
expansion's and the admission's own methods. A popped node the admission refutes is closed and counts as an
expansion with no children; one it skips (superseded) does not count. A popped node whose foothold passes the
target is a goal (``passes``: on a profile its foothold's x reaches the target's; on a height map it crosses the
target's line near the target), and so is an expanded node with a successful hop past the window's far edge (its
sequence goes as far as the robot can see), and a child the expansion marks as one (``Children.goal``)."""
from __future__ import annotations

import types as pytypes
from collections import namedtuple

import numpy as np

from drakeslip.compiled import compiled
from planners.core.clock import N_SLOTS
from planners.core.tree import (EXHAUSTED, GO_ON, GOALS, NO_GOAL, add_children, budget_stop, heap_pop, heap_push,
                                new_frontier, new_tree, passes)

# what ``admit`` says of a popped node
ADMITTED, REFUTED, SKIPPED = 0, 1, 2
FAILED_CHECK = -2   # what ``pop_admitted`` returns for a popped node that was refuted
# the search's limits: sequences wanted, node expansions, step-map calls (NO_LIMIT), the wall-clock deadline
# (``time.perf_counter`` seconds), and what a node with candidates left adds to its cost when it returns to the queue
Limits = namedtuple("Limits", ["n_sequences", "max_nodes", "max_ode_calls", "deadline", "reexpand"])
# what a search returns: the tree (its first ``size`` nodes), the goal nodes in the order found, the expanded nodes
# in order, step-map calls, expansions (refuted nodes included), the stop code, the time slots
Searched = namedtuple("Searched", ["tree", "size", "goals", "expanded", "ode_calls", "expansions", "stop", "slots"])


def start(expansion, admission, root):
    """(the expansion's state, the admission's state) at the start of a search from apex ``root``, as Python: each
    one's own ``start`` method (None without one)."""
    e_state = expansion.start(root) if hasattr(expansion, "start") else None
    return e_state, admission.start(e_state, root) if hasattr(admission, "start") else None


def expand(expansion, state, tree, size, node, slots):
    """The children of ``node`` (``Children``) and the expansion's state after them, as Python: the expansion's own
    ``expand`` method."""
    return expansion.expand(state, tree, size, node, slots)


def admit(admission, state, tree, node, slots):
    """(ADMITTED, REFUTED or SKIPPED; step-map calls; the admission's state after) for the popped ``node``, as
    Python: the admission's own ``admit`` method."""
    return admission.admit(state, tree, node, slots)


def pop_admitted(admission, state, tree, frontier, goals, n_goals, target, slots):
    """Pop nodes until one to expand: (that node, -1 when the frontier runs out or enough goals were found,
    FAILED_CHECK when the admission refuted the popped node; the frontier, the number of goals, step-map calls, the
    admission's state). A popped node that ``passes`` the target is a goal."""
    hops = 0
    while frontier.size > 0:
        i, frontier = heap_pop(frontier)
        verdict, flown, state = admit(admission, state, tree, i, slots)
        hops += flown
        if verdict == SKIPPED:
            continue
        if verdict == REFUTED:
            return FAILED_CHECK, frontier, n_goals, hops, state
        if passes(tree, i, target):
            goals[n_goals] = i
            n_goals += 1
            if n_goals >= goals.shape[0]:
                return -1, frontier, n_goals, hops, state
            continue
        return i, frontier, n_goals, hops, state
    return -1, frontier, n_goals, hops, state


def best_first(expansion, admission, root, target, limits):
    """The search from the apex ``root`` toward ``target`` (see the module doc); a ``Searched``."""
    searching, checking = start(expansion, admission, root)   # the expansion's and the admission's states
    tree = new_tree(root)
    # the counters are int64 from the start: a literal 0 passed on to a compiled function compiles a second copy of it
    size, node = np.int64(1), np.int64(0)
    frontier = new_frontier()
    goals, expanded = np.empty(limits.n_sequences, np.int64), np.empty(limits.max_nodes, np.int64)
    n_goals = ode_calls = expansions = n_expanded = np.int64(0)
    slots = np.zeros(N_SLOTS)
    stop = EXHAUSTED
    while True:
        spent = budget_stop(expansions, limits.max_nodes, ode_calls, limits.max_ode_calls, limits.deadline)
        if spent != GO_ON:
            stop = spent
            break
        if node != FAILED_CHECK:
            children, searching = expand(expansion, searching, tree, size, node, slots)
            expanded[n_expanded] = node
            n_expanded += 1
            expansions += 1
            ode_calls += children.ode_calls
            if children.beyond and node > 0:
                goals[n_goals] = node
                n_goals += 1
                if n_goals >= limits.n_sequences:
                    stop = GOALS
                    break
            first = size
            tree, size, frontier = add_children(tree, size, node, children, frontier)
            if children.goal != NO_GOAL:
                goals[n_goals] = first + children.goal
                n_goals += 1
                if n_goals >= limits.n_sequences:
                    stop = GOALS
                    break
            if children.more:  # back in the queue behind its own children (the root: behind everything)
                frontier = heap_push(frontier, tree.cost[node] + limits.reexpand, node)
        node, frontier, n_goals, hops, checking = pop_admitted(admission, checking, tree, frontier, goals, n_goals,
                                                               target, slots)
        ode_calls += hops
        if node == FAILED_CHECK:  # closed: counts as an expansion with no children
            expansions += 1
        if n_goals >= limits.n_sequences:
            stop = GOALS
            break
        if node == -1:
            break
    return Searched(tree, size, goals[:n_goals], expanded[:n_expanded], ode_calls, expansions, stop, slots)


def bound(function, **names):
    """``function``'s code with some of the names it calls bound to other functions."""
    scope = {**function.__globals__, **names}
    return pytypes.FunctionType(function.__code__, scope, function.__name__, function.__defaults__,
                                function.__closure__)


def specialized(start_search, expand_node, admit_node, tree_kind=None):
    """The loop compiled with the compiled ``start_search``, ``expand_node`` and ``admit_node`` in its calls, on the
    planar tree (``planners.core.tree``), or on the tree whose ``new_tree``, ``add_children`` and ``passes`` are the
    entries of ``tree_kind`` (the spatial one: ``planners.core.spatial_tree.SPATIAL_TREE``)."""
    tree_kind = tree_kind or {}
    pop = compiled()(bound(pop_admitted, admit=admit_node, **{k: v for k, v in tree_kind.items() if k == "passes"}))
    return compiled()(bound(best_first, start=start_search, expand=expand_node, pop_admitted=pop,
                            **{k: v for k, v in tree_kind.items() if k != "passes"}))


python_best_first = best_first   # the loop as Python: its calls of start, expand and admit are the Python ones
