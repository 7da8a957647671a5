"""Step-space's expansion, compiled: the desired footholds on a grid within reach of a node's apex, aimed by the
controller and flown by the step map; the successful ones are the node's children (``StepSpacePlanner`` in
planners/search/step_space.py says what each check is for)."""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from drakeslip.compiled import compiled
from drakeslip.dynamics import I_GRAVITY, I_LEG_LENGTH, height_at
from drakeslip.fast_controller import aim_rows
from drakeslip.fast_correction import set_hop_before, template_step
from drakeslip.fast_step import N_OUT, OK, OUT_CODE, OUT_TD_X, OUT_X, OUT_XDOT, OUT_Z

from planners.core.clock import CONTROLLER, STEP_MAP, now
from planners.core.ground import clear_of_edges_at
from planners.core.tree import NO_GOAL, Children, child_costs

# A grid search's settings: the grid's spacing, the reach's padding, the last foothold (``until``), the edge margin,
# the friction cone's half-angle (``max_angle``), how close a hop must land to its foothold (``tolerance``), the
# next apex's least speed, the perception window's end, the isolation of a child next to a failure
GridSettings = namedtuple("GridSettings", ["spacing", "pad", "until", "edge_margin", "max_angle", "tolerance",
                                           "min_speed", "window_end", "at_failure"])
# The reach angles' sines and cosines (``reach_bounds``)
Reach = namedtuple("Reach", ["sin", "cos"])
# Step-space's expansion: the grid, the map (``drakeslip.terrain.Ground``), the hopper (``SlipParams.as_array``),
# the controller (``ControllerArrays``), the reach angles, the node cost's ``Scoring``, and the hop that reached the
# root as a learned correction takes it (``planners.base.Problem.before``)
GridExpansion = namedtuple("GridExpansion", ["grid", "ground", "params", "controller", "reach", "scoring",
                                             "root_before"])
NO_STATE = 0   # the state of an expansion that keeps none


@compiled(inline="always")
def reach_bounds(x, z, v, ground, p, reach):
    """Bounds on where a flight from apex (x, z, v) can touch down on solid ground with a leg angle at one of the
    reach angles (the friction cone's, ``reach``). The foot, L0 sin(a) ahead of the body, meets ground of height h
    when the body has fallen to h + L0 cos(a): touchdown at x + L0 sin(a) + v sqrt(2 (z - h - L0 cos(a)) / g), taken
    over the highest and the lowest solid ground between a leg behind the body and the farthest fall's end."""
    heights, x0, cell = ground.heights, ground.x0, ground.cell
    leg, g = p[I_LEG_LENGTH], p[I_GRAVITY]
    n = heights.shape[0]
    far = x + leg + v * math.sqrt(2 * max(z - ground.lowest, 0.0) / g)
    first = min(max(int(math.floor((x - leg - x0) / cell)), 0), n - 1)
    last = min(max(int(math.floor((far - x0) / cell)), 0), n - 1)
    high, low, found = -math.inf, math.inf, False
    for i in range(first, last + 1):
        if heights[i] > ground.ditch_height:
            high, low, found = max(high, heights[i]), min(low, heights[i]), True
    if not found:
        high = low = height_at(heights, x0, cell, x)
    lo, hi = math.inf, -math.inf
    for k in range(reach.sin.shape[0]):
        lo = min(lo, x + leg * reach.sin[k] + v * math.sqrt(2 * max(z - high - leg * reach.cos[k], 0.0) / g))
        hi = max(hi, x + leg * reach.sin[k] + v * math.sqrt(2 * max(z - low - leg * reach.cos[k], 0.0) / g))
    return lo, hi


@compiled(inline="always")
def grid_candidates(x, z, v, ground, p, reach, grid):
    """The desired footholds x0 + (i + 1/2) spacing within reach (padded by ``grid.pad``), up to ``grid.until``."""
    lo, hi = reach_bounds(x, z, v, ground, p, reach)
    lo, hi = lo - grid.pad, min(hi + grid.pad, grid.until)
    first = math.ceil((lo - ground.x0) / grid.spacing - 0.5)
    last = math.floor((hi - ground.x0) / grid.spacing - 0.5)
    out = np.empty(max(last - first + 1, 0))
    for j in range(out.shape[0]):
        out[j] = ground.x0 + (float(first + j) + 0.5) * grid.spacing
    return out


@compiled(inline="always")
def aim_candidates(x, z, v, x_l, ground, controller, edge_margin, max_angle):
    """The controller's leg angle from apex (x, z, v) to each of ``x_l``, NaN where the foothold is not admissible
    (a ditch cell, near an edge, or reached only outside the friction cone): one controller call for the admissible
    ones."""
    heights, x0, cell = ground.heights, ground.x0, ground.cell
    n = x_l.shape[0]
    kept, kept_x, kept_ground = np.empty(n, np.int64), np.empty(n), np.empty(n)
    k = 0
    for i in range(n):
        height = height_at(heights, x0, cell, x_l[i])
        if height > ground.ditch_height and clear_of_edges_at(heights, x0, cell, x_l[i], edge_margin):
            kept[k], kept_x[k], kept_ground[k] = i, x_l[i], height
            k += 1
    theta = np.empty(n)
    for i in range(n):
        theta[i] = math.nan
    if k:
        # element by element, not by masks: a masked assignment compiles numba's shape checks and their messages
        apexes = np.empty((k, 3))
        for j in range(k):
            apexes[j, 0], apexes[j, 1], apexes[j, 2] = x, z, v
        aims = aim_rows(apexes, kept_x[:k], kept_ground[:k], controller)
        for j in range(k):
            theta[kept[j]] = aims[j]
    for i in range(n):
        if not abs(theta[i]) < max_angle:
            theta[i] = math.nan
    return theta


@compiled(inline="always")
def node_before(tree, node, ground, root_before):
    """The hop that reached ``node`` as the learned correction takes it (``drakeslip.fast_correction.set_hop_before``):
    ``root_before`` at the root."""
    parent = tree.parent[node]
    if parent < 0:
        return root_before
    before = np.empty(4)
    set_hop_before(before, tree.apex[parent], tree.foothold[node], ground)
    return before


@compiled(inline="always")
def fly(x, z, v, theta, x_l, e, out, before):
    """One step-map call of the expansion ``e`` (its hopper, ground and grid) after the hop ``before``; whether the
    hop succeeds, lands within the grid's tolerance of ``x_l`` and keeps its minimum speed (the next apex is left in
    ``out``)."""
    template_step(x, z, v, theta, e.params, e.ground, before, out)
    return out[OUT_CODE] == OK and abs(out[OUT_TD_X] - x_l) < e.grid.tolerance and out[OUT_XDOT] >= e.grid.min_speed


@compiled(inline="always")
def isolation(x_l, ok, at_failure):
    """D for each successful candidate, in candidate order: the mean spread to its nearest successful siblings on
    either side, the candidates taken in the order they were generated. A neighbour that failed with no success
    beyond it counts ``at_failure``; at the end of the range the spread to the one existing neighbour counts
    twice."""
    idx = np.flatnonzero(ok)
    m, n = idx.shape[0], x_l.shape[0]
    d = np.empty(m)
    for j in range(m):
        left = abs(x_l[idx[j]] - x_l[idx[j - 1]]) if j > 0 else (at_failure if idx[0] > 0 else math.nan)
        right = abs(x_l[idx[j + 1]] - x_l[idx[j]]) if j < m - 1 else (at_failure if idx[-1] < n - 1 else math.nan)
        if math.isnan(left):
            left = right
        if math.isnan(right):
            right = left
        value = 0.5 * (left + right)
        d[j] = at_failure if math.isnan(value) else value
    return d


@compiled(inline="always")
def children_of(x_l, theta, ok, apexes, ode_calls, grid, scoring):
    """The successful candidates inside the window as a node's ``Children`` (a successful one past the window makes
    the node a goal instead: ``beyond``)."""
    d_all = isolation(x_l, ok, grid.at_failure)
    k, beyond = 0, False
    for i in range(x_l.shape[0]):
        if ok[i]:
            if x_l[i] < grid.window_end:
                k += 1
            else:
                beyond = True
    angles, footholds, kid_apexes, d = np.empty(k), np.empty(k), np.empty((k, 3)), np.empty(k)
    rank, c = 0, 0
    for i in range(x_l.shape[0]):
        if not ok[i]:
            continue
        if x_l[i] < grid.window_end:
            angles[c], footholds[c], d[c] = theta[i], x_l[i], d_all[rank]
            kid_apexes[c, 0], kid_apexes[c, 1], kid_apexes[c, 2] = apexes[i, 0], apexes[i, 1], apexes[i, 2]
            c += 1
        rank += 1
    return Children(angles, footholds, kid_apexes, child_costs(footholds, kid_apexes, d, scoring), ode_calls,
                    beyond, False, NO_GOAL)


@compiled()
def expand_grid(expansion, state, tree, size, node, slots):
    """Step-space's expansion of ``node`` (``planners.core.best_first.expand``): its children, and the state (the
    grid keeps none: NO_STATE); adds the controller's and the step map's time to ``slots``."""
    e, grid = expansion, expansion.grid
    x, z, v = tree.apex[node, 0], tree.apex[node, 1], tree.apex[node, 2]
    x_l = grid_candidates(x, z, v, e.ground, e.params, e.reach, grid)
    n = x_l.shape[0]
    t0 = now()
    theta = aim_candidates(x, z, v, x_l, e.ground, e.controller, grid.edge_margin, grid.max_angle)
    t1 = now()
    ok = np.zeros(n, np.bool_)
    apexes = np.zeros((n, 3))
    out = np.empty(N_OUT)
    before = node_before(tree, node, e.ground, e.root_before)
    calls = 0
    for i in range(n):
        if theta[i] == theta[i]:
            ok[i] = fly(x, z, v, theta[i], x_l[i], e, out, before)
            apexes[i, 0], apexes[i, 1], apexes[i, 2] = out[OUT_X], out[OUT_Z], out[OUT_XDOT]
            calls += 1
    t2 = now()
    slots[CONTROLLER] += t1 - t0
    slots[STEP_MAP] += t2 - t1
    return children_of(x_l, theta, ok, apexes, calls, grid, e.scoring), state

