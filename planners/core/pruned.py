"""The planners' pruned last stage, compiled (``planners.search.pruned`` says what it searches and why): Step-space's
grid expansion, apexes merged on (x, xdot) cells, the energy graph's dead apexes dropped, the node farthest ahead
less its risk popped first; a child past the target ends the search."""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import types
from numba.typed import Dict

from drakeslip.compiled import compiled

from planners.core.best_first import ADMITTED, SKIPPED
from planners.core.grid import NO_STATE, expand_grid
from planners.core.tree import CAPACITY, NO_GOAL, Children, grown

# The stage's settings: apexes slower than ``careful`` make a hop risky, the merge cells' size in x and xdot, the
# progress a risky hop costs, the reach and gravity of the energy graph's flights, the target
StageSettings = namedtuple("StageSettings", ["careful", "merge_x", "merge_xdot", "risk_cost", "reach", "gravity",
                                             "target_x"])
# The cells from which the target can be reached, in increasing x (``planners.search.energy_graph.Coreach``): their
# x ranges, tops, and the lowest top
Coreachable = namedtuple("Coreachable", ["lo", "hi", "top", "lowest"])
# The stage's expansion: Step-space's (``GridExpansion``, its minimum speed the stage's), the stage's settings and
# the coreachable cells; its state in a search: each node's risk (slow hops on its path), whether it was expanded,
# and each merge cell's node (``holder``)
PrunedExpansion = namedtuple("PrunedExpansion", ["grid", "stage", "cells"])
PrunedState = namedtuple("PrunedState", ["risk", "expanded", "holder"])
# The stage's admission: a popped node superseded in its merge cell is skipped; its state is the expansion's holder
MergeAdmission = namedtuple("MergeAdmission", ["stage"])


@compiled()
def cell_key(x, xdot, merge_x, merge_xdot):
    """The merge cell of an apex (x, xdot) as one integer."""
    kx = int(math.floor(x / merge_x + 0.5))
    kv = int(math.floor(xdot / merge_xdot + 0.5))
    return kx * 4294967296 + (kv + 2147483648)


@compiled()
def alive(x, z, v, cells, reach, g, target_x):
    """``Coreach.alive`` for one apex: past the target, or its first descent can touch down on one of the
    coreachable ``cells``."""
    if x >= target_x:
        return True
    far = x + v * math.sqrt(2.0 * max(z - cells.lowest, 0.0) / g) + reach
    k = np.searchsorted(cells.hi, x - reach)   # the first cell with hi >= x - reach
    while k < cells.lo.shape[0] and cells.lo[k] <= far:
        if z >= cells.top[k] and cells.lo[k] <= x + v * math.sqrt(2.0 * max(z - cells.top[k], 0.0) / g) + reach:
            return True
        k += 1
    return False


@compiled()
def start_stage(expansion, admission, root):
    """``planners.core.best_first.start`` for the stage: (its expansion's state, its admission's state, the same
    merge cells) from apex ``root``, whose node 0 holds the root's merge cell."""
    stage = expansion.stage
    holder = Dict.empty(key_type=types.int64, value_type=types.int64)   # merge cell -> the node that holds it
    holder[cell_key(root[0], root[2], stage.merge_x, stage.merge_xdot)] = 0
    return PrunedState(np.zeros(CAPACITY, np.int64), np.zeros(CAPACITY, np.bool_), holder), holder


@compiled()
def expand_pruned(expansion, state, tree, size, node, slots):
    """The stage's expansion of ``node`` (``planners.core.best_first.expand``): Step-space's children, the first past
    the target with the least risk alone (a goal), else those alive and first in their merge cell (or less risky
    than its holder not yet expanded), fast hops first, each group in foothold order, queued by risk times
    ``risk_cost`` less their x."""
    e, st = expansion, expansion.stage
    kids, _ = expand_grid(e.grid, NO_STATE, tree, size, node, slots)
    state.expanded[node] = True
    k = kids.angles.shape[0]
    risk, expanded, holder = grown(state.risk, size + k), grown(state.expanded, size + k), state.holder
    state = PrunedState(risk, expanded, holder)
    slow = np.empty(k, np.int64)
    goal, goal_risk = -1, np.int64(0)
    for j in range(k):   # a child past the target ends the search: the first with the least risk
        slow[j] = 1 if kids.apexes[j, 2] < st.careful else 0
        if kids.footholds[j] >= st.target_x and (goal < 0 or risk[node] + slow[j] < goal_risk):
            goal, goal_risk = j, risk[node] + slow[j]
    if goal >= 0:
        risk[size], expanded[size] = goal_risk, False
        return Children(kids.angles[goal:goal + 1], kids.footholds[goal:goal + 1], kids.apexes[goal:goal + 1],
                        np.zeros(1), kids.ode_calls, kids.beyond, False, 0), state
    order = np.empty(k, np.int64)
    keys = np.empty(k)
    n = 0
    for level in range(2):   # fast hops first, each group in foothold order
        for j in range(k):
            if slow[j] != level:
                continue
            a = kids.apexes[j]
            if not alive(a[0], a[1], a[2], e.cells, st.reach, st.gravity, st.target_x):
                continue
            rk = risk[node] + level
            key = cell_key(a[0], a[2], st.merge_x, st.merge_xdot)
            if key in holder:
                held = holder[key]
                if risk[held] <= rk or expanded[held]:
                    continue
            order[n], keys[n] = j, st.risk_cost * rk - a[0]
            risk[size + n], expanded[size + n] = rk, False
            holder[key] = size + n
            n += 1
    chosen = order[:n]
    return Children(kids.angles[chosen], kids.footholds[chosen], kids.apexes[chosen], keys[:n], kids.ode_calls,
                    kids.beyond, False, NO_GOAL), state


@compiled(inline="always")
def merge_admit(admission, state, tree, node, slots):
    """``planners.core.best_first.admit`` for a ``MergeAdmission`` (its state the expansion's merge cells): a popped
    node that no longer holds its merge cell is skipped."""
    a = tree.apex[node]
    if state[cell_key(a[0], a[2], admission.stage.merge_x, admission.stage.merge_xdot)] != node:
        return SKIPPED, 0, state
    return ADMITTED, 0, state
