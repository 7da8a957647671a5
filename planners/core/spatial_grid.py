"""Step-space's expansion on a height map, compiled: the desired footholds on a square grid within reach of a node's
apex, aimed by the spatial controller and flown by the spatial step map; the successful ones are the node's children
(``planners.spatial.step_space`` says what each check is for)."""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from drakeslip.compiled import compiled
from drakeslip.dynamics import I_GRAVITY, I_LEG_LENGTH
from drakeslip.spatial.controller import aim
from drakeslip.spatial.dynamics import cell_of, height_at
from drakeslip.spatial.fast_step import N_OUT, OK, OUT_CODE, OUT_TD_X, OUT_TD_Y, OUT_TD_Z, OUT_X, OUT_XDOT, OUT_Y, \
    OUT_YDOT, OUT_Z, step_one
from drakeslip.terrain import LEVEL_TOLERANCE

from planners.core.clock import CONTROLLER, STEP_MAP, now
from planners.core.spatial_tree import child_costs
from planners.core.tree import NO_GOAL, Children

# A spatial grid search's settings: the grid's spacing, the reach's padding, the edge margin, the friction cone's
# half-angle (``max_tilt``, the leg's angle from vertical), how close a hop must land to its foothold
# (``tolerance``), the next apex's least speed, the known window (x_min, x_max, y_min, y_max), the isolation of a
# child next to a failure, the RK4 steps of a stance
SpatialGrid = namedtuple("SpatialGrid", ["spacing", "pad", "edge_margin", "max_tilt", "tolerance", "min_speed",
                                         "x_min", "x_max", "y_min", "y_max", "at_failure", "stance_steps"])
# The expansion: the grid, the map (``drakeslip.spatial.heightmap.Ground3``), the hopper (``SlipParams.as_array``),
# the node cost's ``SpatialScoring``, and the robust check's particles (``RobustParticles``: none for a nominal search)
SpatialExpansion = namedtuple("SpatialExpansion", ["grid", "ground", "params", "scoring", "particles"])
# The robust check's particles: each one's error of the apex the planner is told (x, y, z, xdot, ydot: the true apex
# is the told one less it) and of the leg's angles (pitch, roll), (K, 7), and the hopper it flies (K, 6)
RobustParticles = namedtuple("RobustParticles", ["errors", "params"])
NO_STATE = 0


@compiled(inline="always")
def start_spatial(expansion, admission, root):
    """The search's start: neither the grid nor the nominal admission keeps a state."""
    return NO_STATE, NO_STATE


@compiled(inline="always")
def admit_every(admission, state, tree, node, slots):
    """The nominal search's admission: every popped node is expanded (``planners.core.best_first.ADMITTED``)."""
    return 0, 0, state


@compiled(inline="always")
def solid_range(x, y, radius, ground):
    """The highest and the lowest solid height within ``radius`` of (x, y) (a square of cells), or both the height
    under (x, y) where every cell there is a hole."""
    j0, i0 = cell_of(x - radius, y - radius, ground)
    j1, i1 = cell_of(x + radius, y + radius, ground)
    high, low = -math.inf, math.inf
    for j in range(j0, j1 + 1):
        for i in range(i0, i1 + 1):
            h = ground.heights[j, i]
            if h > ground.ditch_height:
                high, low = max(high, h), min(low, h)
    if high == -math.inf:
        high = low = height_at(x, y, ground)
    return high, low


@compiled(inline="always")
def reach_disk(a, ground, p, grid):
    """(centre x, centre y, radius) of a disk holding every touchdown a flight from apex ``a`` can make with the leg
    inside the friction cone: the foot leaves up to L0 sin(max_tilt) from the body in any direction, and the body
    drifts with its speed for a fall to the highest to the lowest solid ground it can reach; padded by ``grid.pad``."""
    leg, g = p[I_LEG_LENGTH], p[I_GRAVITY]
    x, y, z, vx, vy = a[0], a[1], a[2], a[3], a[4]
    speed = math.sqrt(vx * vx + vy * vy)
    longest = math.sqrt(2.0 * max(z - ground.lowest, 0.0) / g)
    high, low = solid_range(x + 0.5 * vx * longest, y + 0.5 * vy * longest, leg + 0.5 * speed * longest, ground)
    t_short = math.sqrt(2.0 * max(z - high - leg, 0.0) / g)
    t_long = math.sqrt(2.0 * max(z - low - leg * math.cos(grid.max_tilt), 0.0) / g)
    t_mid = 0.5 * (t_short + t_long)
    radius = leg * math.sin(grid.max_tilt) + 0.5 * speed * (t_long - t_short) + grid.pad
    return x + vx * t_mid, y + vy * t_mid, radius


@compiled(inline="always")
def clear_of_edges(x, y, level, margin, ground):
    """Whether the map is solid and of ``level`` (within LEVEL_TOLERANCE) at the eight points ``margin`` around
    (x, y): no face or hole edge near the foothold."""
    for k in range(8):
        angle = 0.25 * math.pi * k
        h = height_at(x + margin * math.cos(angle), y + margin * math.sin(angle), ground)
        if h <= ground.ditch_height or abs(h - level) > LEVEL_TOLERANCE:
            return False
    return True


@compiled(inline="always")
def foothold_height(x, y, grid, ground):
    """The ground's height at (x, y) where a foothold may go there (inside the known window, solid, clear of edges
    by the grid's margin), NaN where not."""
    if not (grid.x_min <= x < grid.x_max and grid.y_min <= y < grid.y_max):
        return math.nan
    h = height_at(x, y, ground)
    if h <= ground.ditch_height or not clear_of_edges(x, y, h, grid.edge_margin, ground):
        return math.nan
    return h


@compiled(inline="always")
def candidates(a, e):
    """The desired footholds (x, y, z) of the grid (cell centres of ``spacing`` from the map's origin) inside the reach
    disk and the known window, on solid ground clear of edges; and their (row, column) on the grid's square around
    the disk (for the isolation)."""
    grid, ground = e.grid, e.ground
    cx, cy, radius = reach_disk(a, ground, e.params, grid)
    s = grid.spacing
    i0, j0 = math.ceil((cx - radius - ground.x0) / s - 0.5), math.ceil((cy - radius - ground.y0) / s - 0.5)
    n = int(2.0 * radius / s) + 2
    out, where = np.empty((n * n, 3)), np.empty((n * n, 2), np.int64)
    k = 0
    for dj in range(n):
        for di in range(n):
            x, y = ground.x0 + (i0 + di + 0.5) * s, ground.y0 + (j0 + dj + 0.5) * s
            if (x - cx) ** 2 + (y - cy) ** 2 > radius * radius:
                continue
            h = foothold_height(x, y, grid, ground)
            if math.isnan(h):
                continue
            out[k, 0], out[k, 1], out[k, 2] = x, y, h
            where[k, 0], where[k, 1] = dj, di
            k += 1
    return out[:k], where[:k], n


@compiled(inline="always")
def isolation(where, ok, n, spacing, at_failure):
    """D of each successful candidate: the mean over its four grid neighbours of ``spacing`` where that neighbour
    succeeded and ``at_failure`` where it did not (or was no candidate): a foothold in the middle of a wide
    feasible patch scores low, one at its edge high."""
    flown = np.zeros((n, n), np.bool_)
    for k in range(where.shape[0]):
        if ok[k]:
            flown[where[k, 0], where[k, 1]] = True
    d = np.empty(where.shape[0])
    for k in range(where.shape[0]):
        j, i, total = where[k, 0], where[k, 1], 0.0
        for dj, di in ((0, 1), (0, -1), (1, 0), (-1, 0)):
            jj, ii = j + dj, i + di
            good = 0 <= jj < n and 0 <= ii < n and flown[jj, ii]
            total += spacing if good else at_failure
        d[k] = 0.25 * total
    return d


@compiled(inline="always")
def survived(a, pitch, roll, level, e, out):
    """Whether every particle of ``e.particles`` flies the hop the planner aimed from the apex it was told, ``a``,
    with the angles (pitch, roll): from its true apex, with its leg's errors, on its hopper, the hop succeeds, lands on
    the target's level (a foot that slid off the foothold's surface or into a hole fails) and keeps the least
    speed."""
    errors, grid = e.particles.errors, e.grid
    for j in range(errors.shape[0]):
        true = (a[0] - errors[j, 0], a[1] - errors[j, 1], a[2] - errors[j, 2], a[3] - errors[j, 3],
                a[4] - errors[j, 4])
        step_one(true, pitch + errors[j, 5], roll + errors[j, 6], e.particles.params[j], e.ground, grid.stance_steps,
                 out)
        if not (out[OUT_CODE] == OK and abs(out[OUT_TD_Z] - level) <= LEVEL_TOLERANCE
                and math.hypot(out[OUT_XDOT], out[OUT_YDOT]) >= grid.min_speed):
            return False
    return True


@compiled(inline="always")
def fly_candidates(a, targets, e, slots):
    """Aim at each desired foothold (x, y, z) of ``targets`` from apex ``a`` and fly the hops the friction cone allows
    on the expansion ``e``'s map: (ok, leg angles, next apexes, step-map calls); ok where the hop succeeds, lands
    within the grid's tolerance, keeps its least speed and, where ``e`` has particles, every particle ``survived``.
    Adds the controller's and the step map's time to ``slots``."""
    grid = e.grid
    m = targets.shape[0]
    ok = np.zeros(m, np.bool_)
    angles, apexes, out = np.empty((m, 2)), np.empty((m, 5)), np.empty(N_OUT)
    calls = 0
    controller_s = step_s = 0.0
    for k in range(m):
        t0 = now()
        pitch, roll, miss = aim(a, (targets[k, 0], targets[k, 1], targets[k, 2]), e.params)
        t1 = now()
        controller_s += t1 - t0
        angles[k, 0], angles[k, 1] = pitch, roll
        if not (miss < 0.5 * grid.tolerance and math.cos(pitch) * math.cos(roll) > math.cos(grid.max_tilt)):
            continue
        step_one(a, pitch, roll, e.params, e.ground, grid.stance_steps, out)
        calls += 1
        apexes[k, 0], apexes[k, 1], apexes[k, 2] = out[OUT_X], out[OUT_Y], out[OUT_Z]
        apexes[k, 3], apexes[k, 4] = out[OUT_XDOT], out[OUT_YDOT]
        ok[k] = out[OUT_CODE] == OK and math.hypot(out[OUT_TD_X] - targets[k, 0], out[OUT_TD_Y] - targets[k, 1]) \
            < grid.tolerance and math.hypot(out[OUT_XDOT], out[OUT_YDOT]) >= grid.min_speed
        if ok[k] and e.particles.errors.shape[0] > 0:
            ok[k] = survived(a, pitch, roll, targets[k, 2], e, out)
            calls += e.particles.errors.shape[0]
        step_s += now() - t1
    slots[CONTROLLER] += controller_s
    slots[STEP_MAP] += step_s
    return ok, angles, apexes, calls


@compiled(inline="always")
def children_from(targets, ok, angles, apexes, isolation_of, calls, scoring):
    """The successful candidates as a node's ``Children``, each with its isolation from ``isolation_of`` (one per
    candidate)."""
    count = 0
    for k in range(ok.shape[0]):
        if ok[k]:
            count += 1
    kid_angles, kid_footholds, kid_apexes, d = np.empty((count, 2)), np.empty((count, 3)), np.empty((count, 5)), \
        np.empty(count)
    c = 0
    for k in range(ok.shape[0]):
        if ok[k]:
            kid_angles[c, 0], kid_angles[c, 1] = angles[k, 0], angles[k, 1]
            for q in range(3):
                kid_footholds[c, q] = targets[k, q]
            for q in range(5):
                kid_apexes[c, q] = apexes[k, q]
            d[c] = isolation_of[k]
            c += 1
    return Children(kid_angles, kid_footholds, kid_apexes, child_costs(kid_footholds, kid_apexes, d, scoring), calls,
                    False, False, NO_GOAL)


@compiled()
def expand_spatial_grid(expansion, state, tree, size, node, slots):
    """Step-space's expansion of ``node`` on a height map (``planners.core.best_first.expand``): its children and the
    state (none); adds the controller's and the step map's time to ``slots``."""
    e = expansion
    a = (tree.apex[node, 0], tree.apex[node, 1], tree.apex[node, 2], tree.apex[node, 3], tree.apex[node, 4])
    targets, where, n = candidates(a, e)
    ok, angles, apexes, calls = fly_candidates(a, targets, e, slots)
    d = isolation(where, ok, n, e.grid.spacing, e.grid.at_failure)
    return children_from(targets, ok, angles, apexes, d, calls, e.scoring), state
