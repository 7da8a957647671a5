"""LSTM-guided sampling's expansion, compiled (``LSTMGuidedPlanner`` in planners/learned/lstm_guided.py with
``conditioning="apex"`` says what it does): a node's candidate footholds on the grid within reach and inside the
window, in the order of a weighted draw without replacement by the footstep model's probabilities from the node's
own apex and window, aimed a few at a time and flown ``width`` at a time until one succeeds; a node with candidates
left is expanded again when the search comes back to it (``Children.more``)."""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import types
from numba.typed import Dict, List

from drakeslip.compiled import compiled
from drakeslip.fast_step import N_OUT, OUT_X, OUT_XDOT, OUT_Z

from planners.core.clock import CONTROLLER, MODEL, STEP_MAP, now
from planners.core.grid import aim_candidates, children_of, fly, grid_candidates, node_before
from planners.core.model import encode, first_gates, first_step_logits, masked_softmax
from planners.core.tree import Children, copy_head, grown

# The footstep model's window on the map: its cells, the cell under the body among them (``anchor``), the model's
# cell under the body (``s0``), the hopper's length and speed units, the depth a ditch reads as, the model's bins per
# cell, whether it masks ditches, the sampling temperature, and the floor of every candidate's weight
WindowSettings = namedtuple("WindowSettings", ["n_cells", "anchor", "s0", "length", "speed", "ditch_floor",
                                               "subcells", "mask_ditches", "temperature", "floor"])
# The search's draws: each expanded node's slot (``slot_of``) and, per slot, its candidates' offset in the flat
# candidate arrays, how many, how many are in the draw's order, how far that order is used, and the aimed candidates
# waiting to be flown (``n_ready`` of ``ready``); the flat candidates' x, leg angles and draw orders (``used`` of
# them, one entry); the model's first layer's input gates per (window, bin under the body) seen (``window_keys`` ->
# row of ``gates``)
SampledState = namedtuple("SampledState", ["slot_of", "start", "count", "n_order", "pos", "n_ready", "ready",
                                           "cand_x", "cand_theta", "cand_order", "used", "window_keys", "gates"])
# LSTM-guided sampling's expansion: Step-space's (``GridExpansion``'s fields), the window, the model's arrays
# (``ModelArrays``), the draws' generator, how many candidates are flown at a time (``width``); its state in a search
# is the draws (``SampledState``)
SampledExpansion = namedtuple("SampledExpansion", ["grid", "ground", "params", "controller", "reach", "scoring",
                                                   "root_before", "window", "model", "rng", "width"])
KEY_STRIDE = 1 << 20  # a (window start, bin under the body) pair's key: start * KEY_STRIDE + bin
FLOAT_ROW = types.float64[::1]


@compiled()
def _f32(x):
    return float(np.float32(x))


@compiled()
def node_window(x, z, xdot, ground, win):
    """``planners.learned.inputs.encode_window`` for a terrain whose cells are the model's: (window start index,
    relative heights, ditch cells, apex features, bin under the body, x of the window's start)."""
    heights, x0, cell, ditch_height = ground.heights, ground.x0, ground.cell, ground.ditch_height
    n, n_terrain = int(win.n_cells), heights.shape[0]
    first = int(math.floor((x - x0) / cell)) - int(win.anchor)
    s0 = int(win.s0)
    raw, ditch = np.empty(n), np.empty(n, np.bool_)
    for j in range(n):
        raw[j] = heights[min(max(first + j, 0), n_terrain - 1)]
        ditch[j] = raw[j] <= ditch_height
    level, found = 0.0, False
    for j in range(min(s0, n - 1), -1, -1):
        if not ditch[j]:
            level, found = raw[j], True
            break
    if not found:
        for j in range(n):
            if not ditch[j]:
                level = raw[j]
                break
    length = win.length
    rel = np.empty(n)
    for j in range(n):
        h = min(raw[j], win.ditch_floor) if ditch[j] else raw[j]
        rel[j] = _f32(min(max((h - level) / length, -1.0), 1.0))
    offset = min(max((x - x0) / cell - math.floor((x - x0) / cell), 0.0), 1.0)
    features = np.array([_f32((z - level) / length), _f32(xdot / win.speed), _f32(offset)])
    subcells = int(win.subcells)
    s0_bin = s0 * subcells + min(int(features[2] * subcells), subcells - 1)
    return first, rel, ditch, features, s0_bin, x0 + first * cell


@compiled()
def node_probabilities(x, z, xdot, x_l, e, state):
    """The model's probability of each candidate's bin for the step after the node at apex (x, z, xdot), 0 outside
    the window and (with ditch masking) in ditches (``e``: the expansion, its ground, window and model); a window
    and bin seen before in the search reuse their encoding's input gates (``state.window_keys`` -> row of
    ``state.gates``, a list grown here)."""
    ground, win, model, keys, gates = e.ground, e.window, e.model, state.window_keys, state.gates
    first, rel, ditch, features, s0_bin, x_start = node_window(x, z, xdot, ground, win)
    key = first * KEY_STRIDE + s0_bin
    if key not in keys:
        keys[key] = len(gates)
        gates.append(first_gates(encode(rel, s0_bin, model), model))
    row = keys[key]
    subcells = int(win.subcells)
    n_bins = model.head_b.shape[0]
    bin_width = ground.cell / subcells
    bins = np.empty(x_l.shape[0], np.int64)
    for i in range(x_l.shape[0]):
        bins[i] = int(math.floor((x_l[i] - x_start) / bin_width))
    # The draw's order is that of p scaled by any positive factor (``weighted_order``), so without a floor the
    # candidates' probabilities need not be normalized over every bin: the head runs for their bins alone.
    wanted = bins[(bins >= 0) & (bins < n_bins)] if win.floor == 0.0 else np.empty(0, np.int64)
    logits = first_step_logits(features, gates[row], model, wanted)
    mask = np.zeros(n_bins, np.bool_)
    if win.mask_ditches:
        for j in range(n_bins):
            mask[j] = ditch[j // subcells]
    probs = masked_softmax(logits, win.temperature, mask)
    p = np.zeros(x_l.shape[0])
    for i in range(x_l.shape[0]):
        if 0 <= bins[i] < n_bins:
            p[i] = probs[bins[i]]
    return p


@compiled()
def weighted_order(p, rng):
    """``planners.learned.lstm_guided.weighted_order``: the indices with p > 0 in a weighted draw's order."""
    idx = np.flatnonzero(p > 0)
    u = rng.uniform(0.0, 1.0, idx.shape[0])
    keys = np.empty(idx.shape[0])
    for j in range(idx.shape[0]):
        keys[j] = -(math.log(u[j]) / p[idx[j]])
    return idx[np.argsort(keys)]


@compiled()
def new_state(width):
    """The draws of a search that has expanded nothing yet (``width``: candidates flown at a time); made in compiled
    code, where making a typed dict or list takes microseconds, not the milliseconds it takes from Python."""
    return SampledState(Dict.empty(types.int64, types.int64), np.empty(64, np.int64), np.empty(64, np.int64),
                        np.empty(64, np.int64), np.empty(64, np.int64), np.empty(64, np.int64),
                        np.empty((64, 5 * width), np.int64), np.empty(1024), np.empty(1024),
                        np.empty(1024, np.int64), np.zeros(1, np.int64), Dict.empty(types.int64, types.int64),
                        List.empty_list(FLOAT_ROW))


@compiled(inline="always")
def with_room(state, slot, more):
    """``state`` with room for slot ``slot``'s draws and ``more`` candidates after those used."""
    used = state.used[0]
    return SampledState(state.slot_of, grown(state.start, slot + 1), grown(state.count, slot + 1),
                        grown(state.n_order, slot + 1), grown(state.pos, slot + 1), grown(state.n_ready, slot + 1),
                        grown(state.ready, slot + 1), grown(state.cand_x, used + more),
                        grown(state.cand_theta, used + more), grown(state.cand_order, used + more), state.used,
                        state.window_keys, state.gates)


@compiled(inline="always")
def draw_candidates(e, state, node, x, z, v, slots):
    """``node``'s first expansion (apex (x, z, v)): its candidates in the draw's order, kept in a new slot of
    ``state``; the state after."""
    x_l = grid_candidates(x, z, v, e.ground, e.params, e.reach, e.grid)
    t0 = now()
    prob = node_probabilities(x, z, v, x_l, e, state)
    slots[MODEL] += now() - t0
    order = weighted_order(np.maximum(prob, e.window.floor), e.rng)
    slot = len(state.slot_of)
    state.slot_of[node] = slot
    state = with_room(state, slot, x_l.shape[0])
    used = state.used[0]
    state.start[slot], state.count[slot], state.n_order[slot] = used, x_l.shape[0], order.shape[0]
    state.pos[slot], state.n_ready[slot] = 0, 0
    copy_head(state.cand_x[used:], x_l, x_l.shape[0])
    for j in range(x_l.shape[0]):
        state.cand_theta[used + j] = math.nan
    copy_head(state.cand_order[used:], order, order.shape[0])
    state.used[0] = used + x_l.shape[0]
    return state


@compiled(inline="always")
def aim_next(e, state, slot, apex, x_l, theta, order, slots):
    """Aim the slot's next candidates (from ``apex``, (x, z, v)) in the draw's order, a few at a time, until
    ``e.width`` wait to be flown or none is left; the admissible ones join the slot's ready ones."""
    x, z, v = apex
    width = e.width
    while state.n_ready[slot] < width and state.pos[slot] < order.shape[0]:  # aiming is the cost: lazily
        chunk = order[state.pos[slot]:state.pos[slot] + 4 * width]
        state.pos[slot] += chunk.shape[0]
        t0 = now()
        aims = aim_candidates(x, z, v, x_l[chunk], e.ground, e.controller, e.grid.edge_margin, e.grid.max_angle)
        slots[CONTROLLER] += now() - t0
        for j in range(chunk.shape[0]):
            i = chunk[j]
            theta[i] = aims[j]
            if theta[i] == theta[i]:
                state.ready[slot, state.n_ready[slot]] = i
                state.n_ready[slot] += 1


@compiled()
def expand_sampled(e, state, tree, size, node, slots):
    """LSTM-guided sampling's expansion of ``node`` (``planners.core.best_first.expand``, see the module doc): its
    children, and the draws (``state``) after."""
    grid = e.grid
    x, z, v = tree.apex[node, 0], tree.apex[node, 1], tree.apex[node, 2]
    if node not in state.slot_of:
        state = draw_candidates(e, state, node, x, z, v, slots)
    slot = state.slot_of[node]
    first, n = state.start[slot], state.count[slot]
    x_l, theta = state.cand_x[first:first + n], state.cand_theta[first:first + n]
    order = state.cand_order[first:first + state.n_order[slot]]
    ok, apexes, tried = np.zeros(n, np.bool_), np.zeros((n, 3)), np.empty(n, np.int64)
    out = np.empty(N_OUT)
    before = node_before(tree, node, e.ground, e.root_before)
    n_tried = calls = 0
    while state.pos[slot] < order.shape[0] or state.n_ready[slot] > 0:
        aim_next(e, state, slot, (x, z, v), x_l, theta, order, slots)
        batch = min(e.width, state.n_ready[slot])
        hit = False
        t0 = now()
        for b in range(batch):
            i = state.ready[slot, b]
            tried[n_tried] = i
            n_tried += 1
            ok[i] = fly(x, z, v, theta[i], x_l[i], e, out, before)
            apexes[i, 0], apexes[i, 1], apexes[i, 2] = out[OUT_X], out[OUT_Z], out[OUT_XDOT]
            hit = hit or ok[i]
        slots[STEP_MAP] += now() - t0
        for b in range(state.n_ready[slot] - batch):   # the ones not flown move to the front
            state.ready[slot, b] = state.ready[slot, batch + b]
        state.n_ready[slot] -= batch
        calls += batch
        if hit:
            break
    idx = np.sort(tried[:n_tried])
    children = children_of(x_l[idx], theta[idx], ok[idx], apexes[idx], calls, grid, e.scoring)
    more = state.pos[slot] < order.shape[0] or state.n_ready[slot] > 0
    return Children(children.angles, children.footholds, children.apexes, children.keys, children.ode_calls,
                    children.beyond, more, children.goal), state
