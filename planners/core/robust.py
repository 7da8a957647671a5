"""The robust levels' check of a popped node, compiled (``planners.search.robust.Robustness`` says what it asks): the
particles that reached the node's parent aim at its foothold with the controller from the apexes they are told and
fly there (``fly_particles``); a node of the sequence's first ``depth`` hops is admitted only if all of them make
it, and its particles are where they land. At depth 0 it admits every node: the nominal search's admission, of the
same type, so one compiled search serves both."""
from __future__ import annotations

from collections import namedtuple

import numpy as np

from drakeslip.compiled import compiled
from drakeslip.dynamics import height_at
from drakeslip.fast_controller import aim_rows
from drakeslip.fast_correction import set_hop_before

from planners.core.best_first import ADMITTED, REFUTED
from planners.core.clock import CONTROLLER, STEP_MAP, now
from planners.core.particles import NO_FAN, Worlds, fly_particles
from planners.core.tree import CAPACITY, copy_head, grown

# The particles' errors and worlds, and what a robust hop asks of them: how many of a sequence's first hops they
# fly (``depth``, 0: no check), the way-on check at the last (``lookahead`` working hops among the ``fan``'s leg
# angles, each the first of ``lookahead_depth``), their apex and leg-angle errors, the world each hops in and its
# terrain's shift from the map, the margins (``clearance`` above the ground at the next apex, ``landing`` distance
# to the foothold, ``edge_margin``, ``min_speed``).
RobustCheck = namedtuple("RobustCheck", ["depth", "lookahead", "lookahead_depth", "fan", "apex_errors",
                                         "angle_errors", "world", "shift", "worlds", "clearance", "landing",
                                         "edge_margin", "min_speed"])
# A search's robust admission: the check, the map the planner sees (``drakeslip.terrain.Ground``), the controller
# (``ControllerArrays``), where the root's particles are (P, 3), and the hop that reached the root as a learned
# correction takes it (``planners.base.Problem.before``)
class RobustAdmission(namedtuple("RobustAdmission", ["check", "ground", "controller", "root_states", "root_before"])):
    __slots__ = ()

    def start(self, expansion_state, root):
        """The admission's state at the start of a search run as Python: the flights of the compiled search's."""
        return start_flights(self)

    def admit(self, state, tree, node, slots):
        """``admit`` in a search run as Python: the compiled check."""
        return robust_admit(self, state, tree, node, slots)


# The particles' flights in a search: each node's row of ``states`` (-1: none), how many rows are set (``rows``, one
# entry), the particles' apexes per row
Flights = namedtuple("Flights", ["row_of", "rows", "states"])


def no_check(ground, controller, root_before) -> RobustAdmission:
    """The nominal search's admission (depth 0: every node admitted), of the types a robust one has (the worlds'
    heights read-only, as a Terrain's), so one compiled search serves both."""
    heights = np.zeros((0, 1))
    heights.setflags(write=False)
    check = RobustCheck(0, 0, 1, NO_FAN, np.zeros((0, 3)), np.zeros(0), np.zeros(0, np.int64), np.zeros(0),
                        Worlds(np.zeros((0, 6)), heights, np.zeros(0), 0.0, 0.0), 0.0, 0.0, 0.0, 0.0)
    return RobustAdmission(check, ground, controller, np.zeros((0, 3)), root_before)


@compiled(inline="always")
def start_flights(admission):
    """The flights at a search's start: the root's particles, where the check flies any (depth > 0)."""
    states = np.empty((16,) + admission.root_states.shape)
    row_of = np.full(CAPACITY, -1, np.int64)
    rows = np.zeros(1, np.int64)
    if admission.check.depth > 0:
        copy_head(states, admission.root_states.reshape((1,) + admission.root_states.shape), 1)
        row_of[0], rows[0] = 0, 1
    return Flights(row_of, rows, states)


@compiled(inline="always")
def aim_particles(check, states, foothold, ground, controller):
    """The leg angle each particle reaches, aiming at ``foothold`` from the apex it is told (its state plus its
    apex error) with its leg-angle error, inside +-1.5 rad."""
    n = states.shape[0]
    ground_height = height_at(ground.heights, ground.x0, ground.cell, foothold)
    aims = aim_rows(states + check.apex_errors, np.full(n, foothold), np.full(n, ground_height), controller)
    angles = np.empty(n)
    for i in range(n):
        angles[i] = min(max(aims[i] + check.angle_errors[i], -1.5), 1.5)
    return angles


@compiled(inline="always")
def robust_admit(admission, state, tree, node, slots):
    """``planners.core.best_first.admit`` for a ``RobustAdmission``: (ADMITTED or REFUTED, hops flown, the flights
    (``state``) with the node's particles added when admitted)."""
    flights = state
    check, row_of, states = admission.check, flights.row_of, flights.states
    depth = tree.depth[node]
    if check.depth == 0 or depth > check.depth or (node < row_of.shape[0] and row_of[node] >= 0):
        return ADMITTED, 0, flights
    parent = tree.parent[node]
    here = states[row_of[parent]]
    foothold = tree.foothold[node]
    befores = np.empty((here.shape[0], 4))   # the hops that brought the particles to the parent
    grandparent = tree.parent[parent]
    for i in range(here.shape[0]):
        if grandparent < 0:
            for k in range(4):
                befores[i, k] = admission.root_before[k]
        else:
            set_hop_before(befores[i], states[row_of[grandparent], i], tree.foothold[parent], admission.ground)
    t0 = now()
    angles = aim_particles(check, here, foothold, admission.ground, admission.controller)
    t1 = now()
    fan = check.fan if depth == check.depth else NO_FAN
    passed, ends, hops = fly_particles(check, here, befores, angles, foothold, admission.ground, fan)
    slots[CONTROLLER] += t1 - t0
    slots[STEP_MAP] += now() - t1
    if not passed:
        return REFUTED, hops, flights
    if node >= row_of.shape[0]:
        wider = np.full(max(2 * row_of.shape[0], node + 1), -1, np.int64)
        copy_head(wider, row_of, row_of.shape[0])
        row_of = wider
    rows = flights.rows[0]
    states = grown(states, rows + 1)
    copy_head(states[rows:], ends.reshape((1,) + ends.shape), 1)
    row_of[node] = rows
    flights.rows[0] = rows + 1
    return ADMITTED, hops, Flights(row_of, flights.rows, states)
