"""The robust levels' check of a popped node, compiled (``StepSpacePlanner.admission`` and ``Robustness.fly`` in
planners/search/ say what it asks): the particles that reached the node's parent aim at its foothold with the
controller from the apexes they are told and fly there (``fly_particles``); a node of the sequence's first
``depth`` hops is kept only if all of them make it, and its particles are where they land."""
from __future__ import annotations

import numpy as np
from numba import njit, types
from numba.typed import Dict

from drakeslip.dynamics import height_at
from drakeslip.fast_controller import aim_rows

from planners.core.clock import CONTROLLER, STEP_MAP, now
from planners.core.tree import heap_pop
from planners.search.robust import NO_FAN, fly_particles

FAILED_CHECK = -2  # what ``pop_admitted`` returns for a popped node that failed the check
# fields of a robustness tuple (``robust_arrays``)
(DEPTH, LOOKAHEAD, STATES, APEX_ERRORS, ANGLE_ERRORS, WORLD, SHIFT, W_PARAMS, W_HEIGHTS, W_X0, CLEARANCE, LANDING,
 EDGE_MARGIN, MIN_SPEED, FAN, LOOKAHEAD_DEPTH) = range(16)


# the core's tuple for no robust check (depth 0): nothing in it is read or written
NO_CHECK = (0, 0, np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), np.zeros(0, np.int64), np.zeros(0),
            np.zeros((0, 6)), np.zeros((0, 1)), np.zeros(0), 0.0, 0.0, 0.0, 0.0, NO_FAN, 1)


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


@njit(cache=True)
def root_flights(rob):
    """(node -> its particles' row in ``flights``, the particles' states by row), holding the root's particles
    where the robust check flies any (depth > 0); it grows as nodes pass the check."""
    flight_of, flights = Dict.empty(types.int64, types.int64), np.empty((16,) + rob[STATES].shape)
    if rob[DEPTH] > 0:
        flight_of[0] = 0
        flights[0] = rob[STATES]
    return flight_of, flights


@njit(cache=True)
def admit(tree, node, rob, flight_of, flights, terr, net, slots):
    """Whether the popped ``node`` passes the robust check, the hops flown, and the flights array (grown when
    full; the node's particles are added to it when it passes)."""
    depth = tree[5][node]
    if rob[DEPTH] == 0 or node in flight_of or depth > rob[DEPTH]:
        return True, 0, flights
    here = flights[flight_of[tree[0][node]]]
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
        row = len(flight_of)
        if row == flights.shape[0]:
            grown = np.empty((2 * row, n, 3))
            grown[:row] = flights
            flights = grown
        flights[row] = ends
        flight_of[node] = row
    return passed, hops, flights


@njit(cache=True)
def pop_admitted(tree, keys, ids, heap, goals, n_goals, target_x, rob, flight_of, flights, terr, net, slots):
    """``pop_next`` with the robust check of each popped node (before it can be a goal or be expanded). Returns
    (the node to expand, -1 when none, FAILED_CHECK when a popped node failed it; the heap's size; the number of
    goals; hops flown; the flights array)."""
    hops = 0
    while heap > 0:
        i, heap = heap_pop(keys, ids, heap)
        passed, flown, flights = admit(tree, i, rob, flight_of, flights, terr, net, slots)
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
