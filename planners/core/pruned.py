"""The planners' pruned last stage, compiled (``planners.search.pruned`` says what it searches and why): Step-space's
grid expansion (``expand_grid``), apexes merged on (x, xdot) cells, the energy graph's dead apexes dropped, the node
farthest ahead less its risk popped first."""
from __future__ import annotations

import math

import numpy as np
from numba import types
from numba.typed import Dict

from drakeslip.compiled import compiled
from planners.core.clock import N_SLOTS
from planners.core.grid import expand_grid
from planners.core.tree import (CAPACITY, EXHAUSTED, GO_ON, GOALS, NO_LIMIT, budget_stop, grown, heap_pop, heap_push, new_tree,
                                reserve)

# fields of the stage's settings array (``planners.search.pruned.pruned_search`` fills it)
CAREFUL, MERGE_X, MERGE_XDOT, RISK_COST, REACH, GRAVITY_G, TARGET_X = range(7)


@compiled()
def cell_key(x, xdot, merge_x, merge_xdot):
    """The merge cell of an apex (x, xdot) as one integer."""
    kx = int(math.floor(x / merge_x + 0.5))
    kv = int(math.floor(xdot / merge_xdot + 0.5))
    return kx * 4294967296 + (kv + 2147483648)


@compiled()
def alive(x, z, v, cells, reach, g, target_x):
    """``Coreach.alive`` for one apex: past the target, or its first descent can touch down on one of ``cells`` (lo,
    hi, top, lowest top: the cells from which the target can be reached, in increasing x)."""
    if x >= target_x:
        return True
    lo, hi, top, lowest = cells
    far = x + v * math.sqrt(2.0 * max(z - lowest, 0.0) / g) + reach
    k = np.searchsorted(hi, x - reach)   # the first cell with hi >= x - reach
    while k < lo.shape[0] and lo[k] <= far:
        if z >= top[k] and lo[k] <= x + v * math.sqrt(2.0 * max(z - top[k], 0.0) / g) + reach:
            return True
        k += 1
    return False


@compiled()
def add_node(tree, size, risk, expanded_flag, node, angle, foothold, apex, priority, rk):
    """Node ``size``: the child of ``node`` at ``apex`` with its queue priority and risk, not yet expanded."""
    parent, angles, footholds, apexes, cost, depth = tree
    parent[size], angles[size], footholds[size], cost[size] = node, angle, foothold, priority
    depth[size], risk[size], expanded_flag[size] = depth[node] + 1, rk, False
    apexes[size, 0], apexes[size, 1], apexes[size, 2] = apex[0], apex[1], apex[2]


@compiled()
def pruned_best_first(root, terr, p, net, sin_a, cos_a, s, stage, cells, max_nodes, deadline):
    """The stage from apex ``root`` with grid settings ``s`` (``planners.core.grid``), stage settings ``stage``
    (CAREFUL..TARGET_X) and the coreachable ``cells`` (``alive``). Returns (tree, its size, goals, expanded nodes,
    step-map calls, expansions, stop code, time slots)."""
    careful, merge_x, merge_xdot, risk_cost = stage[CAREFUL], stage[MERGE_X], stage[MERGE_XDOT], stage[RISK_COST]
    reach, g, target_x = stage[REACH], stage[GRAVITY_G], stage[TARGET_X]
    tree = new_tree(root[0], root[1], root[2])
    size = np.int64(1)   # int64 counters, not literals: see planners/core/search.py
    risk, expanded_flag = np.zeros(CAPACITY, np.int64), np.zeros(CAPACITY, np.bool_)
    seen = Dict.empty(key_type=types.int64, value_type=types.int64)   # merge cell -> the node that holds it
    seen[cell_key(root[0], root[2], merge_x, merge_xdot)] = 0
    keys, ids, heap = np.empty(CAPACITY), np.empty(CAPACITY, np.int64), np.int64(0)
    keys, ids, heap = heap_push(keys, ids, heap, -root[0], np.int64(0))
    goals, expanded = np.empty(1, np.int64), np.empty(max_nodes, np.int64)
    n_goals = ode_calls = expansions = np.int64(0)
    slots = np.zeros(N_SLOTS)
    stop = EXHAUSTED
    while heap > 0:
        spent = budget_stop(expansions, max_nodes, ode_calls, np.int64(NO_LIMIT), deadline)
        if spent != GO_ON:
            stop = spent
            break
        node, heap = heap_pop(keys, ids, heap)
        a = tree[3][node]
        if seen[cell_key(a[0], a[2], merge_x, merge_xdot)] != node:
            continue   # superseded by a safer arrival in its cell
        angles, footholds, apexes, d, calls, beyond = expand_grid(a[0], a[1], a[2], terr, p, net, sin_a, cos_a, s,
                                                                  slots)
        expanded[expansions] = node
        expansions += 1
        ode_calls += calls
        expanded_flag[node] = True
        if beyond and node > 0:
            goals[0], n_goals, stop = node, 1, GOALS
            break
        k = angles.shape[0]
        tree = reserve(tree, size, k)
        risk, expanded_flag = grown(risk, size + k), grown(expanded_flag, size + k)
        slow = np.empty(k, np.int64)
        goal, goal_risk = -1, np.int64(0)
        for j in range(k):   # a child past the target ends the search: the first with the least risk
            slow[j] = 1 if apexes[j, 2] < careful else 0
            if footholds[j] >= target_x and (goal < 0 or risk[node] + slow[j] < goal_risk):
                goal, goal_risk = j, risk[node] + slow[j]
        if goal >= 0:
            add_node(tree, size, risk, expanded_flag, node, angles[goal], footholds[goal], apexes[goal], 0.0, goal_risk)
            goals[0], n_goals, stop = size, 1, GOALS
            size += 1
            break
        for level in range(2):   # fast hops first, each group in foothold order
            for j in range(k):
                if slow[j] != level:
                    continue
                if not alive(apexes[j, 0], apexes[j, 1], apexes[j, 2], cells, reach, g, target_x):
                    continue
                rk = risk[node] + level
                key = cell_key(apexes[j, 0], apexes[j, 2], merge_x, merge_xdot)
                if key in seen:
                    held = seen[key]
                    if risk[held] <= rk or expanded_flag[held]:
                        continue
                priority = risk_cost * rk - apexes[j, 0]
                add_node(tree, size, risk, expanded_flag, node, angles[j], footholds[j], apexes[j], priority, rk)
                seen[key] = size
                keys, ids, heap = heap_push(keys, ids, heap, priority, size)
                size += 1
    return tree, size, goals[:n_goals], expanded[:expansions], ode_calls, expansions, stop, slots
