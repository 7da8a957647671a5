"""The robust levels' check of a popped node, compiled (``StepSpacePlanner.admission`` and ``Robustness.fly`` in
planners/search/ say what it asks): the particles that reached the node's parent aim at its foothold with the
controller from the apexes they are told and fly there (``fly_particles``); a node of the sequence's first
``depth`` hops is kept only if all of them make it, and its particles are where they land."""
from __future__ import annotations

import numpy as np

from drakeslip.compiled import compiled
from drakeslip.dynamics import height_at
from drakeslip.fast_controller import aim_rows

from planners.core.clock import CONTROLLER, STEP_MAP, now
from planners.core.tree import CAPACITY, copy_head, grown, heap_pop
from planners.search.robust import NO_FAN, fly_particles

FAILED_CHECK = -2  # what ``pop_admitted`` returns for a popped node that failed the check
# fields of a robustness tuple (``robust_arrays``)
(DEPTH, LOOKAHEAD, STATES, APEX_ERRORS, ANGLE_ERRORS, WORLD, SHIFT, W_PARAMS, W_HEIGHTS, W_X0, CLEARANCE, LANDING,
 EDGE_MARGIN, MIN_SPEED, FAN, LOOKAHEAD_DEPTH) = range(16)


def no_check() -> tuple:
    """The core's tuple for no robust check (depth 0), of the same types as ``robust_arrays``'s (the worlds' heights
    read-only), so one compiled search serves both: nothing in it is read or written."""
    heights = np.zeros((0, 1))
    heights.setflags(write=False)
    return (0, 0, np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), np.zeros(0, np.int64), np.zeros(0),
            np.zeros((0, 6)), heights, np.zeros(0), 0.0, 0.0, 0.0, 0.0, NO_FAN, 1)


NO_CHECK = no_check()


def robust_arrays(robustness, problem) -> tuple:
    """``robustness``'s particles for ``problem`` as the core's tuple; depth 0 (no check) for None."""
    if robustness is None:
        return NO_CHECK
    particles = robustness.particles(problem.apex, problem.terrain, problem.params)
    w = particles.worlds
    return (int(robustness.depth), int(robustness.lookahead), particles.states, particles.apex_errors,
            particles.angle_errors, particles.world.astype(np.int64), particles.shift.astype(np.float64), w.params,
            w.heights, w.x0, float(particles.clearance), float(particles.landing), float(particles.edge_margin),
            float(particles.min_speed), particles.fan if robustness.lookahead else NO_FAN,
            int(robustness.lookahead_depth))


@compiled(inline="always")
def root_flights(rob):
    """The particles' flights: (each node's row in ``states``, -1 where it has none; how many rows are set; the
    particles' states (rows, P, 3)), holding the root's particles where the robust check flies any (depth > 0).
    They grow as nodes pass the check."""
    row_of = np.full(CAPACITY, -1, np.int64)
    states = np.empty((16,) + rob[STATES].shape)
    rows = np.int64(0)
    if rob[DEPTH] > 0:
        row_of[0], rows = 0, 1
        copy_head(states, rob[STATES].reshape((1,) + rob[STATES].shape), 1)
    return row_of, rows, states


@compiled(inline="always")
def admit(tree, node, rob, flights, terr, net, slots):
    """Whether the popped ``node`` passes the robust check, the hops flown, and the flights (``root_flights``; the
    node's particles are added when it passes)."""
    row_of, rows, states = flights
    depth = tree[5][node]
    if rob[DEPTH] == 0 or depth > rob[DEPTH] or (node < row_of.shape[0] and row_of[node] >= 0):
        return True, 0, flights
    here = states[row_of[tree[0][node]]]
    foothold = tree[2][node]
    heights, x0, cell, ditch, _ = terr
    n = here.shape[0]
    errors, angle_errors = rob[APEX_ERRORS], rob[ANGLE_ERRORS]
    ground = height_at(heights, x0, cell, foothold)
    t0 = now()
    aims = aim_rows(here + errors, np.full(n, foothold), np.full(n, ground), net)
    angles = np.empty(n)
    for i in range(n):
        angles[i] = min(max(aims[i] + angle_errors[i], -1.5), 1.5)
    t1 = now()
    fan = rob[FAN] if depth == rob[DEPTH] else NO_FAN
    passed, ends, hops = fly_particles(here, angles, rob[WORLD], rob[SHIFT], rob[W_PARAMS], rob[W_HEIGHTS],
                                       rob[W_X0], cell, ditch, foothold, heights, x0, rob[LANDING], rob[MIN_SPEED],
                                       rob[CLEARANCE], rob[EDGE_MARGIN], fan, rob[LOOKAHEAD], rob[LOOKAHEAD_DEPTH])
    slots[CONTROLLER] += t1 - t0
    slots[STEP_MAP] += now() - t1
    if passed:
        if node >= row_of.shape[0]:
            wider = np.full(max(2 * row_of.shape[0], node + 1), -1, np.int64)
            copy_head(wider, row_of, row_of.shape[0])
            row_of = wider
        states = grown(states, rows + 1)
        copy_head(states[rows:], ends.reshape((1,) + ends.shape), 1)
        row_of[node] = rows
        rows += 1
    return passed, hops, (row_of, rows, states)


@compiled()
def pop_admitted(tree, keys, ids, heap, goals, n_goals, target_x, rob, flights, terr, net, slots):
    """``pop_next`` with the robust check of each popped node (before it can be a goal or be expanded). Returns
    (the node to expand, -1 when none, FAILED_CHECK when a popped node failed it; the heap's size; the number of
    goals; hops flown; the flights array)."""
    hops = 0
    while heap > 0:
        i, heap = heap_pop(keys, ids, heap)
        passed, flown, flights = admit(tree, i, rob, flights, terr, net, slots)
        hops += flown
        if not passed:
            return FAILED_CHECK, heap, n_goals, hops, flights
        if tree[2][i] >= target_x:
            goals[n_goals] = i
            n_goals += 1
            if n_goals >= goals.shape[0]:
                return -1, heap, n_goals, hops, flights
            continue
        return i, heap, n_goals, hops, flights
    return -1, heap, n_goals, hops, flights
