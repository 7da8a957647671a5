"""The best-first search (Algorithm 1 of the paper), once, for every search planner: compiled for the core's
expansions, run as Python for the planners' Python ones.

Expand a node, add its children to the tree and the frontier, pop the cheapest node, check it (``admit``), and go on
until ``n_sequences`` nodes pass the target, the frontier is empty, or a budget is spent. What a search plugs in:

* the **expansion** (``expand(expansion, tree, size, node, slots) -> (Children, expansion)``): Step-space's grid
  (``planners.core.grid.GridExpansion``), the footstep model's samples (``planners.core.sampled``), the pruned last
  stage's merged grid (``planners.core.pruned``), or a Python object with an ``expand`` method (the Drake step map's,
  Angle-space's);
* the **admission** (``admit(admission, tree, node, slots) -> (verdict, step-map calls, admission)``): the robust
  levels' particles (``planners.core.robust.RobustAdmission``, which admits every node at depth 0), the pruned
  stage's merge cells (``planners.core.pruned.MergeAdmission``), or a Python object with an ``admit`` method.

A record's type picks its compiled implementation (``numba.extending.overload`` on ``expand`` and ``admit``), so the
loop is compiled once per (expansion, admission) pair and each pair's code is cached; records of Python objects run
the same loop as Python (``python_best_first``). A popped node the admission refutes is closed and counts as an
expansion with no children; one it skips (superseded) does not count. A popped node whose foothold passes the
target is a goal, and so is an expanded node with a successful hop past the window's far edge (its sequence goes as
far as the robot can see), and a child the expansion marks as one (``Children.goal``)."""
from __future__ import annotations

import types as pytypes
from collections import namedtuple

import numpy as np
from numba.extending import overload

from drakeslip.compiled import compiled
from planners.core.clock import N_SLOTS
from planners.core.tree import (EXHAUSTED, GO_ON, GOALS, NO_GOAL, add_children, budget_stop, heap_pop, heap_push,
                                new_frontier, new_tree)

# the expansion records whose ``start`` adds a state (their modules register it, and their own ``start``)
STATEFUL: set = set()
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
    """(the expansion, the admission) a search from apex ``root`` begins with: what the records given hold, with the
    search's own state added where an expansion keeps one (typed dicts and lists, made here in compiled code: made in
    Python, each would cost the call to the compiled search milliseconds to type). In Python, the expansion's own
    ``start`` method, if it has one."""
    begin = getattr(expansion, "start", None)
    return (expansion, admission) if begin is None else begin(admission, root)


@overload(start)
def _start(expansion, admission, root):
    if getattr(expansion, "instance_class", None) not in STATEFUL:   # a record that keeps no state
        return lambda expansion, admission, root: (expansion, admission)


def expand(expansion, tree, size, node, slots):
    """The children of ``node`` (``Children``) and the expansion as it is after them; in Python, the expansion's own
    ``expand`` method. Compiled expansions register their implementation with ``numba.extending.overload``."""
    return expansion.expand(tree, size, node, slots)


def admit(admission, tree, node, slots):
    """(ADMITTED, REFUTED or SKIPPED; step-map calls; the admission as it is after) for the popped ``node``; in
    Python, the admission's own ``admit`` method."""
    return admission.admit(tree, node, slots)


@compiled()
def pop_admitted(admission, tree, frontier, goals, n_goals, target_x, slots):
    """Pop nodes until one to expand: (that node, -1 when the frontier runs out or enough goals were found,
    FAILED_CHECK when the admission refuted the popped node; the frontier, the number of goals, step-map calls, the
    admission). A popped node past the target is a goal."""
    hops = 0
    while frontier.size > 0:
        i, frontier = heap_pop(frontier)
        verdict, flown, admission = admit(admission, tree, i, slots)
        hops += flown
        if verdict == SKIPPED:
            continue
        if verdict == REFUTED:
            return FAILED_CHECK, frontier, n_goals, hops, admission
        if tree.foothold[i] >= target_x:
            goals[n_goals] = i
            n_goals += 1
            if n_goals >= goals.shape[0]:
                return -1, frontier, n_goals, hops, admission
            continue
        return i, frontier, n_goals, hops, admission
    return -1, frontier, n_goals, hops, admission


@compiled()
def best_first(expansion, admission, root, target_x, limits):
    """The search from apex ``root`` (x, z, xdot) toward ``target_x`` (see the module doc); a ``Searched``."""
    searching, checking = start(expansion, admission, root)   # the records with the search's own state
    tree = new_tree(root[0], root[1], root[2])
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
            children, searching = expand(searching, tree, size, node, slots)
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
        node, frontier, n_goals, hops, checking = pop_admitted(checking, tree, frontier, goals, n_goals, target_x,
                                                               slots)
        ode_calls += hops
        if node == FAILED_CHECK:  # closed: counts as an expansion with no children
            expansions += 1
        if n_goals >= limits.n_sequences:
            stop = GOALS
            break
        if node == -1:
            break
    return Searched(tree, size, goals[:n_goals], expanded[:n_expanded], ode_calls, expansions, stop, slots)


def python_twin(function, *callees):
    """The Python function a compiled ``function`` was compiled from, calling the Python functions of ``callees``
    (compiled functions it calls) where it called them: the same loop for expansions and admissions that are Python
    objects. Every other compiled function it calls stays compiled."""
    source = function.py_func
    scope = dict(source.__globals__)
    for callee in callees:
        scope[callee.py_func.__name__] = callee.py_func
    return pytypes.FunctionType(source.__code__, scope, source.__name__, source.__defaults__, source.__closure__)


python_best_first = python_twin(best_first, pop_admitted)
