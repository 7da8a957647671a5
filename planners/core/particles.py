"""The robust check's flights, compiled: the perturbed robots (particles, ``planners.search.robust.Robustness``) of a
node's parent fly to its foothold, each with its own hopper over its own terrain, and must land where the planner
means them to and be able to go on (``fly_particles``)."""
from __future__ import annotations

from collections import namedtuple

import numpy as np

from drakeslip.compiled import compiled
from drakeslip.dynamics import height_at
from drakeslip.fast_correction import set_hop_before, template_step
from drakeslip.fast_step import N_OUT, OK, OUT_CODE, OUT_TD_X, OUT_X, OUT_XDOT, OUT_Z
from drakeslip.terrain import Ground

from planners.core.ground import clear_of_edges_at, same_level

NO_FAN = np.zeros(0)  # no way-on check
# The particles' hoppers and terrains: world j hops with the parameters ``params[j]`` (``SlipParams.as_array``) over
# ``heights[j]`` from ``x0[j]``; all share ``cell`` and ``ditch_height``.
Worlds = namedtuple("Worlds", ["params", "heights", "x0", "cell", "ditch_height"])


@compiled(inline="always")
def world_ground(worlds, w):
    """World ``w``'s terrain as the step map reads it (its lowest height unused there)."""
    return Ground(worlds.heights[w], worlds.x0[w], worlds.cell, worlds.ditch_height, 0.0)


@compiled()
def fly_particles(check, states, befores, angles, foothold, seen, fan):
    """The flights of a robust check (``planners.core.robust.RobustCheck``): particle i hops from ``states[i]``
    (after the hop ``befores[i]``, for a hopper with a learned correction) with ``angles[i]`` in its world and must
    complete the hop, touch down within ``check.landing`` of ``foothold`` on its level of the map the planner sees
    (``seen``, a ``Ground`` of the worlds' cell), clear of its edges by
    ``check.edge_margin``, and reach its next apex with ``check.min_speed``, ``check.clearance`` above the ground
    under it. Then, for a non-empty ``fan``, each particle must find ``check.lookahead`` leg angles of the fan that
    start a way on of ``check.lookahead_depth`` working hops (``ways_on``). Stops at the first particle that fails
    and searches a particle's ways on only until it has found enough, so the verdict is that of flying every hop and
    the hops flown are fewer. Returns (robust, next apexes (P, 3), hops flown)."""
    worlds = check.worlds
    cell = worlds.cell
    n = states.shape[0]
    ends = np.empty((n, 3))
    touchdowns = np.empty(n)
    out = np.empty(N_OUT)
    hops = 0
    for i in range(n):
        w = check.world[i]
        template_step(states[i, 0], states[i, 1], states[i, 2], angles[i], worlds.params[w], world_ground(worlds, w),
                      befores[i], out)
        hops += 1
        x, z, xdot, touchdown = out[OUT_X], out[OUT_Z], out[OUT_XDOT], out[OUT_TD_X]
        touchdowns[i] = touchdown
        ends[i, 0], ends[i, 1], ends[i, 2] = x, z, xdot
        shift = check.shift[i]
        landed = touchdown - shift  # where it landed on the map the planner sees
        if not (out[OUT_CODE] == OK and abs(touchdown - foothold) <= check.landing and xdot >= check.min_speed
                and z - height_at(seen.heights, seen.x0, cell, x - shift) >= check.clearance
                and same_level(seen.heights, seen.x0, cell, landed, foothold)
                and clear_of_edges_at(seen.heights, seen.x0, cell, landed, check.edge_margin)):
            return False, ends, hops
    for i in range(n if fan.size else 0):
        before = np.empty(4)
        set_hop_before(before, states[i], touchdowns[i], world_ground(worlds, check.world[i]))
        found, flown = ways_on(ends[i], before, fan, check.lookahead, check.lookahead_depth, check, i, seen, out)
        hops += flown
        if found < check.lookahead:
            return False, ends, hops
    return True, ends, hops


@compiled(inline="always")   # many parameters: compiled, per particle in the check's loop, its buffer passed in
def ways_on(apex, before, fan, wanted, depth, check, i, seen, out):
    """(how many of ``fan``'s leg angles, up to ``wanted``, start a way on from ``apex`` after the hop ``before``,
    hops flown) for particle
    ``i`` of ``check``, in its world, whose map (``seen``) is its shift off: a way on is ``depth`` working hops in a
    row (each completes, lands clear of the map's edges by ``check.edge_margin`` and keeps ``check.min_speed``),
    each hop's leg angle taken from ``fan`` in its order; depth first, so the first way on from an angle ends that
    angle's search. ``out``: a step_one output buffer."""
    worlds, w, shift = check.worlds, check.world[i], check.shift[i]
    p, ground, cell = worlds.params[w], world_ground(worlds, w), worlds.cell
    state = np.empty((depth, 3))
    befores = np.empty((depth, 4))   # the hop before each hop of the way
    for k in range(4):
        befores[0, k] = before[k]
    angle = np.zeros(depth, np.int64)  # at each hop of the way being tried, the index of its fan angle
    state[0, 0], state[0, 1], state[0, 2] = apex[0], apex[1], apex[2]
    found = hops = level = 0
    while found < wanted:
        if angle[level] == fan.size:  # no way on from this hop's start: try the hop before it with its next angle
            if level == 0:
                break
            level -= 1
            angle[level] += 1
            continue
        template_step(state[level, 0], state[level, 1], state[level, 2], fan[angle[level]], p, ground,
                      befores[level], out)
        hops += 1
        if not (out[OUT_CODE] == OK and out[OUT_XDOT] >= check.min_speed
                and clear_of_edges_at(seen.heights, seen.x0, cell, out[OUT_TD_X] - shift, check.edge_margin)):
            angle[level] += 1
        elif level + 1 == depth:  # a way on from the first hop's angle: on to the next first angle
            found += 1
            level = 0
            angle[0] += 1
        else:
            set_hop_before(befores[level + 1], state[level], out[OUT_TD_X], ground)
            level += 1
            state[level, 0], state[level, 1], state[level, 2] = out[OUT_X], out[OUT_Z], out[OUT_XDOT]
            angle[level] = 0
    return found, hops
