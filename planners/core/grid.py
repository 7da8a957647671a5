"""Step-space's expansion, compiled: the desired footholds on a grid within reach of a node's apex, aimed by the
controller and flown by the step map; the successful ones are the node's children (``StepSpacePlanner`` in
planners/search/step_space.py says what each check is for, and does the same in numpy)."""
from __future__ import annotations

import math

import numpy as np

from drakeslip.compiled import compiled
from drakeslip.dynamics import I_GRAVITY, I_LEG_LENGTH, height_at
from drakeslip.fast_controller import aim_rows
from drakeslip.fast_step import N_OUT, OK, OUT_CODE, OUT_TD_X, OUT_X, OUT_XDOT, OUT_Z, STANCE_STEPS, step_one

from planners.core.clock import CONTROLLER, STEP_MAP, now
from planners.search.robust import clear_of_edges_at

# fields of a grid search's settings tuple (``grid_settings`` in planners/core/search.py)
SPACING, PAD, UNTIL, EDGE, MAX_ANGLE, TOLERANCE, MIN_SPEED, WINDOW_END, AT_FAILURE = range(9)


@compiled(inline="always")
def reach_bounds(x, z, v, terr, p, sin_a, cos_a):
    """``planners.search.step_space.touchdown_range`` with the reach angles' sines and cosines given."""
    heights, x0, cell, ditch, solid_min = terr
    leg, g = p[I_LEG_LENGTH], p[I_GRAVITY]
    n = heights.shape[0]
    far = x + leg + v * math.sqrt(2 * max(z - solid_min, 0.0) / g)
    first = min(max(int(math.floor((x - leg - x0) / cell)), 0), n - 1)
    last = min(max(int(math.floor((far - x0) / cell)), 0), n - 1)
    high, low, found = -math.inf, math.inf, False
    for i in range(first, last + 1):
        if heights[i] > ditch:
            high, low, found = max(high, heights[i]), min(low, heights[i]), True
    if not found:
        high = low = height_at(heights, x0, cell, x)
    lo, hi = math.inf, -math.inf
    for k in range(sin_a.shape[0]):
        lo = min(lo, x + leg * sin_a[k] + v * math.sqrt(2 * max(z - high - leg * cos_a[k], 0.0) / g))
        hi = max(hi, x + leg * sin_a[k] + v * math.sqrt(2 * max(z - low - leg * cos_a[k], 0.0) / g))
    return lo, hi


@compiled(inline="always")
def grid_candidates(x, z, v, terr, p, sin_a, cos_a, spacing, pad, until):
    """The desired footholds x0 + (i + 1/2) spacing within reach (padded by ``pad``), up to ``until``."""
    lo, hi = reach_bounds(x, z, v, terr, p, sin_a, cos_a)
    lo, hi = lo - pad, min(hi + pad, until)
    x0 = terr[1]
    first, last = math.ceil((lo - x0) / spacing - 0.5), math.floor((hi - x0) / spacing - 0.5)
    out = np.empty(max(last - first + 1, 0))
    for j in range(out.shape[0]):
        out[j] = x0 + (float(first + j) + 0.5) * spacing
    return out


@compiled(inline="always")
def aim_candidates(x, z, v, x_l, terr, net, edge_margin, max_angle):
    """The controller's leg angle from apex (x, z, v) to each of ``x_l``, NaN where the foothold is not admissible
    (a ditch cell, near an edge, or reached only outside the friction cone): one controller call for the admissible
    ones, as ``StepSpacePlanner.aim`` makes it, so the angles are its to the bit."""
    heights, x0, cell, ditch, _ = terr
    n = x_l.shape[0]
    kept, kept_x, kept_ground = np.empty(n, np.int64), np.empty(n), np.empty(n)
    k = 0
    for i in range(n):
        ground = height_at(heights, x0, cell, x_l[i])
        if ground > ditch and clear_of_edges_at(heights, x0, cell, x_l[i], edge_margin):
            kept[k], kept_x[k], kept_ground[k] = i, x_l[i], ground
            k += 1
    theta = np.empty(n)
    for i in range(n):
        theta[i] = math.nan
    if k:
        # element by element, not by masks: a masked assignment compiles numba's shape checks and their messages
        apexes = np.empty((k, 3))
        for j in range(k):
            apexes[j, 0], apexes[j, 1], apexes[j, 2] = x, z, v
        aims = aim_rows(apexes, kept_x[:k], kept_ground[:k], net)
        for j in range(k):
            theta[kept[j]] = aims[j]
    for i in range(n):
        if not abs(theta[i]) < max_angle:
            theta[i] = math.nan
    return theta


@compiled(inline="always")
def fly(x, z, v, theta, x_l, terr, p, tolerance, min_speed, out):
    """One step-map call; whether it succeeds, lands within ``tolerance`` of ``x_l`` and keeps ``min_speed`` (the
    next apex is left in ``out``)."""
    heights, x0, cell, ditch, _ = terr
    step_one(x, z, v, theta, p, heights, x0, cell, ditch, np.int64(STANCE_STEPS), out)
    return out[OUT_CODE] == OK and abs(out[OUT_TD_X] - x_l) < tolerance and out[OUT_XDOT] >= min_speed


@compiled(inline="always")
def isolation(x_l, ok, at_failure):
    """``planners.search.tree.isolation``: D for each successful candidate, in candidate order."""
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
def children_of(x_l, theta, ok, apexes, window_end, at_failure):
    """The successful candidates inside the window as (angles, footholds, apexes, isolation), and whether a
    successful one lands past the window (``StepSpacePlanner.children``)."""
    d_all = isolation(x_l, ok, at_failure)
    k, beyond, j = 0, False, 0
    for i in range(x_l.shape[0]):
        if ok[i]:
            if x_l[i] < window_end:
                k += 1
            else:
                beyond = True
    angles, footholds, kid_apexes, d = np.empty(k), np.empty(k), np.empty((k, 3)), np.empty(k)
    rank, c = 0, 0
    for i in range(x_l.shape[0]):
        if not ok[i]:
            continue
        if x_l[i] < window_end:
            angles[c], footholds[c], d[c] = theta[i], x_l[i], d_all[rank]
            kid_apexes[c, 0], kid_apexes[c, 1], kid_apexes[c, 2] = apexes[i, 0], apexes[i, 1], apexes[i, 2]
            c += 1
        rank += 1
    return angles, footholds, kid_apexes, d, beyond


@compiled()
def expand_grid(x, z, v, terr, p, net, sin_a, cos_a, s, slots):
    """Step-space's expansion of the node at apex (x, z, v) with settings ``s`` (SPACING..AT_FAILURE): returns
    (angles, footholds, apexes, isolation, step-map calls, beyond); adds the controller's and the step map's time
    to ``slots``."""
    x_l = grid_candidates(x, z, v, terr, p, sin_a, cos_a, s[SPACING], s[PAD], s[UNTIL])
    n = x_l.shape[0]
    t0 = now()
    theta = aim_candidates(x, z, v, x_l, terr, net, s[EDGE], s[MAX_ANGLE])
    t1 = now()
    ok = np.zeros(n, np.bool_)
    apexes = np.zeros((n, 3))
    out = np.empty(N_OUT)
    calls = 0
    for i in range(n):
        if theta[i] == theta[i]:
            ok[i] = fly(x, z, v, theta[i], x_l[i], terr, p, s[TOLERANCE], s[MIN_SPEED], out)
            apexes[i, 0], apexes[i, 1], apexes[i, 2] = out[OUT_X], out[OUT_Z], out[OUT_XDOT]
            calls += 1
    t2 = now()
    slots[CONTROLLER] += t1 - t0
    slots[STEP_MAP] += t2 - t1
    angles, footholds, kid_apexes, d, beyond = children_of(x_l, theta, ok, apexes, s[WINDOW_END], s[AT_FAILURE])
    return angles, footholds, kid_apexes, d, calls, beyond
