"""The robust levels' check of a popped node, compiled (``planners.search.robust.Robustness`` says what it asks): the
particles that reached the node's parent aim at its foothold with the controller from the apexes they are told and
fly there (``fly_particles``); a node of the sequence's first ``depth`` hops is admitted only if all of them make
it, and its particles are where they land. At depth 0 it admits every node: the nominal search's admission, of the
same type, so one compiled search serves both."""
from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba.extending import overload

from drakeslip.compiled import compiled
from drakeslip.dynamics import height_at
from drakeslip.fast_controller import aim_rows

from planners.core.best_first import ADMITTED, REFUTED, admit
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
# A search's robust admission: the check, the map the planner sees (``planners.core.grid.Ground``), the controller
# (``ControllerArrays``), and the flights so far: each node's row of ``states`` (-1: none), the rows set (``rows``,
# one entry), the particles' apexes per row.
class RobustAdmission(namedtuple("RobustAdmission", ["check", "ground", "controller", "row_of", "rows", "states"])):
    __slots__ = ()

    def admit(self, tree, node, slots):
        """``admit`` in a search run as Python: the compiled check."""
        return robust_admit(self, tree, node, slots)


def no_check(ground, controller) -> RobustAdmission:
    """The nominal search's admission (depth 0: every node admitted), of the types a robust one has (the worlds'
    heights read-only, as a Terrain's), so one compiled search serves both."""
    heights = np.zeros((0, 1))
    heights.setflags(write=False)
    check = RobustCheck(0, 0, 1, NO_FAN, np.zeros((0, 3)), np.zeros(0), np.zeros(0, np.int64), np.zeros(0),
                        Worlds(np.zeros((0, 6)), heights, np.zeros(0), 0.0, 0.0), 0.0, 0.0, 0.0, 0.0)
    return RobustAdmission(check, ground, controller, np.full(CAPACITY, -1, np.int64), np.zeros(1, np.int64),
                           np.empty((16, 0, 3)))


def robust_admission(check: RobustCheck, states: np.ndarray, ground, controller) -> RobustAdmission:
    """The admission of a search whose root's particles are at ``states`` (P, 3)."""
    flights = np.empty((16,) + states.shape)
    flights[0] = states
    row_of = np.full(CAPACITY, -1, np.int64)
    row_of[0] = 0
    return RobustAdmission(check, ground, controller, row_of, np.ones(1, np.int64), flights)


@compiled()
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


@compiled()
def robust_admit(admission, tree, node, slots):
    """``admit`` for a ``RobustAdmission``: (ADMITTED or REFUTED, hops flown, the admission with the node's
    particles added when admitted)."""
    check, row_of, states = admission.check, admission.row_of, admission.states
    depth = tree.depth[node]
    if check.depth == 0 or depth > check.depth or (node < row_of.shape[0] and row_of[node] >= 0):
        return ADMITTED, 0, admission
    here = states[row_of[tree.parent[node]]]
    foothold = tree.foothold[node]
    t0 = now()
    angles = aim_particles(check, here, foothold, admission.ground, admission.controller)
    t1 = now()
    fan = check.fan if depth == check.depth else NO_FAN
    passed, ends, hops = fly_particles(check, here, angles, foothold, admission.ground, fan)
    slots[CONTROLLER] += t1 - t0
    slots[STEP_MAP] += now() - t1
    if not passed:
        return REFUTED, hops, admission
    if node >= row_of.shape[0]:
        wider = np.full(max(2 * row_of.shape[0], node + 1), -1, np.int64)
        copy_head(wider, row_of, row_of.shape[0])
        row_of = wider
    rows = admission.rows[0]
    states = grown(states, rows + 1)
    copy_head(states[rows:], ends.reshape((1,) + ends.shape), 1)
    row_of[node] = rows
    admission.rows[0] = rows + 1
    return ADMITTED, hops, RobustAdmission(check, admission.ground, admission.controller, row_of, admission.rows,
                                           states)


@overload(admit)
def _admit(admission, tree, node, slots):
    if getattr(admission, "instance_class", None) is RobustAdmission:
        return lambda admission, tree, node, slots: robust_admit(admission, tree, node, slots)
