"""The spatial footstep model's view and forward pass, compiled: the planners' one copy of
``planners.learned.spatial_model.SpatialFootstepModel`` (the torch model it is trained as; tests check the two
agree), and the one function that makes its inputs, for training and planning alike.

The view of a node (``node_view``): a square patch of ``size`` x ``size`` cells of ``cell`` metres, aligned with the
apex's heading (rows forward, columns to the left) and centred where a leg straight down would land from the apex on
the ground under it; each cell reads the map's height under its centre, as (height - apex z) / L0 clipped to
[LOWEST, 1], and whether it is a hole (holes read LOWEST). The apex features: speed / sqrt(g L0), the bearing of the
target from the heading (cos, sin), the distance to the target over L0 / DISTANCE_SCALE (at most 1). The history: the
last ``history`` footholds of the node's branch in the heading frame, from the apex, over L0, each with a flag that it
exists (oldest first). The convolutions also read each cell's place in the patch (``patch_coordinates``). The model
gives a logit per patch cell; the planner's candidates are the points of each of the
most probable cells (``cell_points``)."""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from drakeslip.compiled import compiled
from drakeslip.dynamics import I_GRAVITY, I_LEG_LENGTH
from drakeslip.spatial.dynamics import height_at
from drakeslip.units import units_of

LOWEST = -4.0          # in leg lengths below the apex: a hole, or ground this far down
DISTANCE_SCALE = 20.0  # leg lengths: a target farther than this reads as this far
N_APEX = 4             # apex features
N_HISTORY = 3          # features per past foothold: forward, left, exists
N_COORDS = 2           # the convolutions also read each cell's place in the patch: forward and left, in [-1, 1]
# The view: patch cells per side, their size [m], past footholds, the hopper's leg length and speed unit
ViewSettings = namedtuple("ViewSettings", ["size", "cell", "history", "length", "speed"])
# The model's arrays (float64): the two 3x3 convolutions (out, in, 3, 3) and biases, the LSTM over the history
# (input and recurrent weights (4H, in), (4H, H), gate order i, f, g, o as torch, the two biases summed), the
# conditioning layer (C, N_APEX + H) and bias, the 1x1 head (C,) and bias
SpatialModelArrays = namedtuple("SpatialModelArrays", ["conv1_w", "conv1_b", "conv2_w", "conv2_b", "lstm_wi",
                                                       "lstm_wh", "lstm_b", "cond_w", "cond_b", "head_w", "head_b"])


def view_of(config, params) -> ViewSettings:
    """The view of a model's ``config`` (``planners.learned.config.SpatialModelConfig``: its patch in the paper's
    hopper's metres) for the hopper ``params``, in its units."""
    units = units_of(params)
    return ViewSettings(int(config.size), float(config.cell * units.length), int(config.history),
                        float(params.leg_length), float((params.gravity * params.leg_length) ** 0.5))


@compiled()
def view_frame(apex, ground, p):
    """(centre x, centre y, heading x, heading y) of a node's patch: the heading of the apex's horizontal velocity
    ((1, 0) without one), the centre where a vertical leg lands on the ground under the body."""
    x, y, z, vx, vy = apex[0], apex[1], apex[2], apex[3], apex[4]
    speed = math.sqrt(vx * vx + vy * vy)
    ux, uy = (vx / speed, vy / speed) if speed > 0.0 else (1.0, 0.0)
    leg, g = p[I_LEG_LENGTH], p[I_GRAVITY]
    drop = min(max(z - height_at(x, y, ground) - leg, 0.1 * leg), 3.0 * leg)
    t = math.sqrt(2.0 * drop / g)
    return x + vx * t, y + vy * t, ux, uy


@compiled()
def node_view(apex, history, n_history, target, ground, p, view):
    """The model's inputs at a node: the patch (2, size, size), the apex features (N_APEX,) and the history
    (view.history, N_HISTORY); ``history`` holds the branch's last footholds (x, y), ``n_history`` of them, oldest
    first."""
    cx, cy, ux, uy = view_frame(apex, ground, p)
    n = view.size
    patch = np.empty((2, n, n))
    half = 0.5 * (n - 1)
    for a in range(n):
        for b in range(n):
            f, s = (a - half) * view.cell, (b - half) * view.cell
            h = height_at(cx + f * ux - s * uy, cy + f * uy + s * ux, ground)
            hole = h <= ground.ditch_height
            patch[0, a, b] = LOWEST if hole else min(max((h - apex[2]) / view.length, LOWEST), 1.0)
            patch[1, a, b] = 1.0 if hole else 0.0
    features = np.empty(N_APEX)
    speed = math.sqrt(apex[3] ** 2 + apex[4] ** 2)
    dx, dy = target[0] - apex[0], target[1] - apex[1]
    distance = math.sqrt(dx * dx + dy * dy)
    features[0] = speed / view.speed
    features[1] = (dx * ux + dy * uy) / distance if distance > 0.0 else 1.0
    features[2] = (dy * ux - dx * uy) / distance if distance > 0.0 else 0.0
    features[3] = min(distance / view.length, DISTANCE_SCALE) / DISTANCE_SCALE
    past = np.zeros((view.history, N_HISTORY))
    first = view.history - min(n_history, view.history)
    for k in range(first, view.history):
        hx, hy = history[n_history - view.history + k, 0] - apex[0], history[n_history - view.history + k, 1] - apex[1]
        past[k, 0] = (hx * ux + hy * uy) / view.length
        past[k, 1] = (hy * ux - hx * uy) / view.length
        past[k, 2] = 1.0
    return patch, features, past


@compiled()
def conv3x3(x, w, b, relu):
    """A 3x3 convolution with zero padding of ``x`` (in, n, n) by ``w`` (out, in, 3, 3) and ``b`` (out,). Each output
    sums its terms in torch's reference order (input channel, row, column of the kernel), a whole output plane per
    kernel weight: the inner loops run over contiguous rows of the padded input, with no bounds to test."""
    n_out, n_in, n = w.shape[0], w.shape[1], x.shape[1]
    padded = np.zeros((n_in, n + 2, n + 2))
    for i in range(n_in):
        for a in range(n):
            for c in range(n):
                padded[i, a + 1, c + 1] = x[i, a, c]
    out = np.empty((n_out, n, n))
    for o in range(n_out):
        for a in range(n):
            for c in range(n):
                out[o, a, c] = b[o]
        for i in range(n_in):
            for da in range(3):
                for dc in range(3):
                    weight = w[o, i, da, dc]
                    for a in range(n):
                        for c in range(n):
                            out[o, a, c] += weight * padded[i, a + da, c + dc]
        if relu:
            for a in range(n):
                for c in range(n):
                    out[o, a, c] = max(out[o, a, c], 0.0)
    return out


@compiled()
def sigmoid(v):
    return 1.0 / (1.0 + math.exp(-v))


@compiled()
def history_state(past, m):
    """The LSTM's last hidden state over the history rows (torch's gate order i, f, g, o)."""
    hidden = m.lstm_wh.shape[1]
    h, c = np.zeros(hidden), np.zeros(hidden)
    for t in range(past.shape[0]):
        gates = m.lstm_b.copy()
        for r in range(4 * hidden):
            total = 0.0
            for k in range(past.shape[1]):
                total += m.lstm_wi[r, k] * past[t, k]
            for k in range(hidden):
                total += m.lstm_wh[r, k] * h[k]
            gates[r] += total
        for k in range(hidden):
            i, f = sigmoid(gates[k]), sigmoid(gates[hidden + k])
            g, o = math.tanh(gates[2 * hidden + k]), sigmoid(gates[3 * hidden + k])
            c[k] = f * c[k] + i * g
            h[k] = o * math.tanh(c[k])
    return h


@compiled()
def patch_coordinates(size):
    """(N_COORDS, size, size): each cell's row and column in the patch, scaled to [-1, 1]: a convolution alone is the
    same everywhere in the patch, and where the hop lands depends on the place as much as on the ground there."""
    out = np.empty((N_COORDS, size, size))
    for a in range(size):
        for c in range(size):
            out[0, a, c] = 2.0 * a / (size - 1) - 1.0
            out[1, a, c] = 2.0 * c / (size - 1) - 1.0
    return out


@compiled()
def logits_of(patch, features, past, m):
    """The model's logit of each patch cell (size, size)."""
    n = patch.shape[1]
    image = np.empty((patch.shape[0] + N_COORDS, n, n))
    image[:patch.shape[0]] = patch
    image[patch.shape[0]:] = patch_coordinates(n)
    z1 = conv3x3(image, m.conv1_w, m.conv1_b, True)
    z2 = conv3x3(z1, m.conv2_w, m.conv2_b, False)
    h = history_state(past, m)
    channels = z2.shape[0]
    out = np.full((n, n), m.head_b[0])
    for o in range(channels):
        bias = m.cond_b[o]
        for k in range(features.shape[0]):
            bias += m.cond_w[o, k] * features[k]
        for k in range(h.shape[0]):
            bias += m.cond_w[o, features.shape[0] + k] * h[k]
        for a in range(n):
            for c in range(n):
                out[a, c] += m.head_w[o] * max(z2[o, a, c] + bias, 0.0)
    return out


@compiled()
def cell_points(apex, a, c, ground, p, view, split):
    """The ``split`` x ``split`` footholds (x, y) of patch cell (a, c): the centres of its parts."""
    cx, cy, ux, uy = view_frame(apex, ground, p)
    half = 0.5 * (view.size - 1)
    out = np.empty((split * split, 2))
    k = 0
    for qa in range(split):
        for qc in range(split):
            f = (a - half - 0.5 + (qa + 0.5) / split) * view.cell
            s = (c - half - 0.5 + (qc + 0.5) / split) * view.cell
            out[k, 0], out[k, 1] = cx + f * ux - s * uy, cy + f * uy + s * ux
            k += 1
    return out


@compiled()
def cell_of_point(apex, x, y, ground, p, view):
    """(row, column) of the patch cell holding the point (x, y), (-1, -1) outside the patch."""
    cx, cy, ux, uy = view_frame(apex, ground, p)
    half = 0.5 * (view.size - 1)
    a = int(math.floor(((x - cx) * ux + (y - cy) * uy) / view.cell + half + 0.5))
    c = int(math.floor((-(x - cx) * uy + (y - cy) * ux) / view.cell + half + 0.5))
    if 0 <= a < view.size and 0 <= c < view.size:
        return a, c
    return -1, -1
