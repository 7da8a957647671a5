"""LSTM-guided sampling's expansion, compiled (``LSTMGuidedPlanner`` in planners/learned/lstm_guided.py with
``conditioning="apex"`` says what it does and runs the same in numpy): a node's candidate footholds on the grid
within reach and inside the window, in the order of a weighted draw without replacement by the footstep model's
probabilities from the node's own apex and window, aimed a few at a time and flown ``width`` at a time until one
succeeds; a node with candidates left is expanded again when the search comes back to it."""
from __future__ import annotations

import math

import numpy as np
from numba import types
from numba.typed import Dict

from drakeslip.compiled import compiled
from drakeslip.fast_step import N_OUT, OUT_X, OUT_XDOT, OUT_Z

from planners.core.clock import CONTROLLER, MODEL, N_SLOTS, STEP_MAP, now
from planners.core.grid import (AT_FAILURE, EDGE, MAX_ANGLE, MIN_SPEED, PAD, SPACING, TOLERANCE, UNTIL,
                                WINDOW_END, aim_candidates, children_of, fly, grid_candidates)
from planners.core.model import encode, first_gates, first_step_logits, masked_softmax
from planners.core.robust import FAILED_CHECK, pop_admitted, root_flights
from planners.core.tree import CAPACITY, EXHAUSTED, GO_ON, GOALS, add_children, budget_stop, grown, heap_push, new_tree

# fields of the window settings tuple (``window_settings`` in planners/core/search.py)
N_CELLS, ANCHOR, S0, LENGTH, SPEED, DITCH_FLOOR, SUBCELLS, MASK_DITCHES, TEMPERATURE, FLOOR = range(10)
KEY_STRIDE = 1 << 20  # a (window start, bin under the body) pair's key: start * KEY_STRIDE + bin


@compiled()
def _f32(x):
    return float(np.float32(x))


@compiled()
def node_window(x, z, xdot, terr, win):
    """``planners.learned.inputs.encode_window`` for a terrain whose cells are the model's: (window start index,
    relative heights, ditch cells, apex features, bin under the body, x of the window's start)."""
    heights, x0, cell, ditch_height, _ = terr
    n, n_terrain = int(win[N_CELLS]), heights.shape[0]
    first = int(math.floor((x - x0) / cell)) - int(win[ANCHOR])
    s0 = int(win[S0])
    raw, ditch = np.empty(n), np.empty(n, np.bool_)
    for j in range(n):
        raw[j] = heights[min(max(first + j, 0), n_terrain - 1)]
        ditch[j] = raw[j] <= ditch_height
    ground, found = 0.0, False
    for j in range(min(s0, n - 1), -1, -1):
        if not ditch[j]:
            ground, found = raw[j], True
            break
    if not found:
        for j in range(n):
            if not ditch[j]:
                ground = raw[j]
                break
    length = win[LENGTH]
    rel = np.empty(n)
    for j in range(n):
        h = min(raw[j], win[DITCH_FLOOR]) if ditch[j] else raw[j]
        rel[j] = _f32(min(max((h - ground) / length, -1.0), 1.0))
    offset = min(max((x - x0) / cell - math.floor((x - x0) / cell), 0.0), 1.0)
    features = np.array([_f32((z - ground) / length), _f32(xdot / win[SPEED]), _f32(offset)])
    subcells = int(win[SUBCELLS])
    s0_bin = s0 * subcells + min(int(features[2] * subcells), subcells - 1)
    return first, rel, ditch, features, s0_bin, x0 + first * cell


@compiled()
def node_probabilities(x, z, xdot, x_l, terr, win, model, keys, gates):
    """The model's probability of each candidate's bin for the step after the node at apex (x, z, xdot), 0 outside
    the window and (with ditch masking) in ditches; a window and bin seen before in the search reuse their
    encoding's input gates (``keys`` -> row of ``gates``, a list grown here)."""
    first, rel, ditch, features, s0_bin, x_start = node_window(x, z, xdot, terr, win)
    key = first * KEY_STRIDE + s0_bin
    if key not in keys:
        keys[key] = len(gates)
        gates.append(first_gates(encode(rel, s0_bin, model), model))
    row = keys[key]
    subcells = int(win[SUBCELLS])
    n_bins = model[13].shape[0]
    bin_width = terr[2] / subcells
    bins = np.empty(x_l.shape[0], np.int64)
    for i in range(x_l.shape[0]):
        bins[i] = int(math.floor((x_l[i] - x_start) / bin_width))
    # The draw's order is that of p scaled by any positive factor (``weighted_order``), so without a floor the
    # candidates' probabilities need not be normalized over every bin: the head runs for their bins alone.
    wanted = bins[(bins >= 0) & (bins < n_bins)] if win[FLOOR] == 0.0 else np.empty(0, np.int64)
    logits = first_step_logits(features, gates[row], model, wanted)
    mask = np.zeros(n_bins, np.bool_)
    if win[MASK_DITCHES]:
        for j in range(n_bins):
            mask[j] = ditch[j // subcells]
    probs = masked_softmax(logits, win[TEMPERATURE], mask)
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
def sampled_best_first(root, terr, p, net, sin_a, cos_a, s, win, model, rng, width, rob, target_x, weights,
                       reexpand, n_sequences, max_nodes, max_ode_calls, deadline):
    """``best_first`` with LSTM-guided sampling's expansion (grid settings ``s``, window settings ``win``, the
    model's arrays ``model``, random draws from ``rng``, ``width`` candidates flown at a time). Returns what
    ``grid_best_first`` returns."""
    tree = new_tree(root[0], root[1], root[2])
    size, node, heap = np.int64(1), np.int64(0), np.int64(0)   # int64 counters: see planners/core/search.py
    keys, ids = np.empty(CAPACITY), np.empty(CAPACITY, np.int64)
    goals, expanded = np.empty(n_sequences, np.int64), np.empty(max_nodes, np.int64)
    n_goals = ode_calls = expansions = n_expanded = np.int64(0)  # expansions also count nodes that failed the check
    slots = np.zeros(N_SLOTS)
    window_keys = Dict.empty(types.int64, types.int64)
    gates = [np.empty(0)]  # typed by its first entry, which no key names
    gates.pop()
    slot_of = Dict.empty(types.int64, types.int64)
    # per slot (an expanded node): its candidates' offset in the flat arrays, how many, how many drawn, used
    start, count, n_order, pos, n_ready = (np.empty(64, np.int64), np.empty(64, np.int64), np.empty(64, np.int64),
                                           np.empty(64, np.int64), np.empty(64, np.int64))
    ready = np.empty((64, 5 * width), np.int64)
    cand_x, cand_theta, cand_order = np.empty(1024), np.empty(1024), np.empty(1024, np.int64)
    n_cand = 0
    out = np.empty(N_OUT)
    flights = root_flights(rob)
    stop = EXHAUSTED
    while True:
        spent = budget_stop(expansions, max_nodes, ode_calls, max_ode_calls, deadline)
        if spent != GO_ON:
            stop = spent
            break
        if node != FAILED_CHECK:
            x, z, v = tree[3][node, 0], tree[3][node, 1], tree[3][node, 2]
            if node not in slot_of:
                x_l = grid_candidates(x, z, v, terr, p, sin_a, cos_a, s[SPACING], s[PAD], s[UNTIL])
                t0 = now()
                prob = node_probabilities(x, z, v, x_l, terr, win, model, window_keys, gates)
                slots[MODEL] += now() - t0
                order = weighted_order(np.maximum(prob, win[FLOOR]), rng)
                slot = len(slot_of)
                slot_of[node] = slot
                start, count, n_order, pos, n_ready = (grown(start, slot + 1), grown(count, slot + 1),
                                                       grown(n_order, slot + 1), grown(pos, slot + 1),
                                                       grown(n_ready, slot + 1))
                ready = grown(ready, slot + 1)
                cand_x, cand_theta = grown(cand_x, n_cand + x_l.shape[0]), grown(cand_theta, n_cand + x_l.shape[0])
                cand_order = grown(cand_order, n_cand + x_l.shape[0])
                start[slot], count[slot], n_order[slot] = n_cand, x_l.shape[0], order.shape[0]
                pos[slot], n_ready[slot] = 0, 0
                cand_x[n_cand:n_cand + x_l.shape[0]] = x_l
                cand_theta[n_cand:n_cand + x_l.shape[0]] = math.nan
                cand_order[n_cand:n_cand + order.shape[0]] = order
                n_cand += x_l.shape[0]
            slot = slot_of[node]
            first, n = start[slot], count[slot]
            x_l, theta = cand_x[first:first + n], cand_theta[first:first + n]
            order = cand_order[first:first + n_order[slot]]
            ok, apexes, tried = np.zeros(n, np.bool_), np.zeros((n, 3)), np.empty(n, np.int64)
            n_tried = calls = 0
            while pos[slot] < order.shape[0] or n_ready[slot] > 0:
                while n_ready[slot] < width and pos[slot] < order.shape[0]:  # aiming is the cost: lazily
                    chunk = order[pos[slot]:pos[slot] + 4 * width]
                    pos[slot] += chunk.shape[0]
                    t0 = now()
                    theta[chunk] = aim_candidates(x, z, v, x_l[chunk], terr, net, s[EDGE], s[MAX_ANGLE])
                    slots[CONTROLLER] += now() - t0
                    for i in chunk:
                        if theta[i] == theta[i]:
                            ready[slot, n_ready[slot]] = i
                            n_ready[slot] += 1
                batch = min(width, n_ready[slot])
                hit = False
                t0 = now()
                for b in range(batch):
                    i = ready[slot, b]
                    tried[n_tried] = i
                    n_tried += 1
                    ok[i] = fly(x, z, v, theta[i], x_l[i], terr, p, s[TOLERANCE], s[MIN_SPEED], out)
                    apexes[i, 0], apexes[i, 1], apexes[i, 2] = out[OUT_X], out[OUT_Z], out[OUT_XDOT]
                    hit = hit or ok[i]
                slots[STEP_MAP] += now() - t0
                ready[slot, :n_ready[slot] - batch] = ready[slot, batch:n_ready[slot]].copy()
                n_ready[slot] -= batch
                calls += batch
                if hit:
                    break
            idx = np.sort(tried[:n_tried])
            angles, footholds, kid_apexes, d, beyond = children_of(x_l[idx], theta[idx], ok[idx], apexes[idx],
                                                                   s[WINDOW_END], s[AT_FAILURE])
            more = pos[slot] < order.shape[0] or n_ready[slot] > 0
            expanded[n_expanded] = node
            n_expanded += 1
            expansions += 1
            ode_calls += calls
            if beyond and node > 0:
                goals[n_goals] = node
                n_goals += 1
                if n_goals >= n_sequences:
                    stop = GOALS
                    break
            tree, size, keys, ids, heap = add_children(tree, size, node, angles, footholds, kid_apexes, d, target_x,
                                                       weights, keys, ids, heap)
            if more:  # back in the queue behind its own children (the root: behind everything)
                keys, ids, heap = heap_push(keys, ids, heap, tree[4][node] + reexpand, node)
        node, heap, n_goals, hops, flights = pop_admitted(tree, keys, ids, heap, goals, n_goals, target_x, rob,
                                                          flights, terr, net, slots)
        ode_calls += hops
        if node == FAILED_CHECK:  # closed: counts as an expansion with no children
            expansions += 1
        if n_goals >= n_sequences:
            stop = GOALS
            break
        if node == -1:
            break
    return tree, size, goals[:n_goals], expanded[:n_expanded], ode_calls, expansions, stop, slots
