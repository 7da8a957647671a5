"""The footstep model's forward pass compiled, for the sampled search's nodes (planners/core/sampled.py).

A node's first-step distribution (``conditioning="apex"``: the model restarted from the node's own apex and window)
is the model's CNN encoding of the window and the bin under the body, an LSTM step from the state ``g0`` gives for
the apex, and the head. The encoding and the first layer's input gates depend only on the window and that bin,
which nodes may share, so they are computed once per (window, bin) and kept for the rest of the search; a node
costs the apex's initial state, the recurrent products and the head, the head only for the bins of the node's
candidates where the search needs no more. Weights are the trained model's (``ModelArrays``), the arithmetic
float64 as in planners/learned/inference.py (tests/test_core.py checks it against torch)."""
from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def tanh(x):
    """tanh from one exp (a quarter of libm's tanh's cost), within 3e-16 of it."""
    e = math.exp(-2.0 * abs(x))
    return math.copysign((1.0 - e) / (1.0 + e), x)


@njit(cache=True, fastmath={"contract"})
def affine(x, w, b, out):
    """out = x @ w + b (w stored (inputs, outputs)): each output summed in input order with fused multiply-adds,
    the outputs side by side and four inputs a pass, so the sums vectorize without reordering."""
    n_in, n_out = w.shape
    out[:] = 0.0
    k = 0
    while k + 4 <= n_in:
        x0, x1, x2, x3 = x[k], x[k + 1], x[k + 2], x[k + 3]
        if x0 != 0.0 or x1 != 0.0 or x2 != 0.0 or x3 != 0.0:
            for j in range(n_out):
                acc = out[j]
                acc += x0 * w[k, j]
                acc += x1 * w[k + 1, j]
                acc += x2 * w[k + 2, j]
                acc += x3 * w[k + 3, j]
                out[j] = acc
        k += 4
    while k < n_in:
        xk = x[k]
        for j in range(n_out):
            out[j] += xk * w[k, j]
        k += 1
    for j in range(n_out):
        out[j] += b[j]


def stored(matrix: np.ndarray) -> np.ndarray:
    """A large weight matrix as float32 when that holds it exactly (a model trained in float32): half the memory a
    node's products stream through, the same float64 arithmetic (each weight converts exactly)."""
    single = np.ascontiguousarray(matrix, dtype=np.float32)
    return single if np.array_equal(single.astype(np.float64), matrix) else np.ascontiguousarray(matrix)


class ModelArrays:
    """A ``FootstepModel``'s weights for compiled code, each layer's matrix stored (inputs, outputs): ``astuple``
    gives (g0_w, g0_b, conv1_w (out, in, taps), conv1_b, conv2_w, conv2_b, fc_w, fc_b, the first layer's w_ih
    (in, 4H), the later layers' w_ih (layers - 1, H, 4H), w_hh (layers, H, 4H), b (layers, 4H), head_w, head_b,
    subcells)."""

    def __init__(self, model):
        w = {k: v.detach().double().cpu().numpy() for k, v in model.state_dict().items()}
        c = model.config
        self.config = c
        layers = range(c.layers)
        self.arrays = (np.ascontiguousarray(w["g0.weight"].T), w["g0.bias"].copy(), w["cnn.0.weight"].copy(),
                       w["cnn.0.bias"].copy(), w["cnn.2.weight"].copy(), w["cnn.2.bias"].copy(),
                       stored(w["cnn.5.weight"].T), w["cnn.5.bias"].copy(), stored(w["lstm.weight_ih_l0"].T),
                       stored(np.stack([w[f"lstm.weight_ih_l{k}"].T for k in layers[1:]]).reshape(
                           c.layers - 1, c.hidden, 4 * c.hidden)),
                       stored(np.stack([w[f"lstm.weight_hh_l{k}"].T for k in layers])),
                       np.stack([w[f"lstm.bias_ih_l{k}"] + w[f"lstm.bias_hh_l{k}"] for k in layers]),
                       stored(w["head.weight"].T), w["head.bias"].copy(), int(c.subcells))

    def astuple(self) -> tuple:
        return self.arrays


@njit(cache=True, fastmath={"contract"})
def _conv_relu(x, w, b):
    """A 1-D convolution with 'same' zero padding, then ReLU: x (in, n), w (out, in, taps) -> (out, n); each output
    summed over (input, tap) in order, the cells side by side."""
    n_out, n_in, taps = w.shape
    n = x.shape[1]
    half = taps // 2
    padded = np.zeros((n_in, n + 2 * half))
    padded[:, half:half + n] = x
    y = np.zeros((n_out, n))
    for o in range(n_out):
        row = y[o]
        for i in range(n_in):
            for t in range(taps):
                wt = w[o, i, t]
                shifted = padded[i, t:t + n]
                for c in range(n):
                    row[c] += wt * shifted[c]
        for c in range(n):
            y[o, c] = max(y[o, c] + b[o], 0.0)
    return y


@njit(cache=True)
def encode(window, prev_bin, net):
    """The CNN's encoding (the LSTM's input) of the window's relative heights and a one-hot previous step at bin
    ``prev_bin``."""
    conv1_w, conv1_b, conv2_w, conv2_b, fc_w, fc_b, subcells = net[2], net[3], net[4], net[5], net[6], net[7], net[14]
    n = window.shape[0]
    image = np.zeros((1 + subcells, n))
    image[0] = window
    image[1 + prev_bin % subcells, prev_bin // subcells] = 1.0
    features = _conv_relu(_conv_relu(image, conv1_w, conv1_b), conv2_w, conv2_b).reshape(-1)
    out = np.empty(fc_w.shape[1])
    affine(features, fc_w, fc_b, out)
    for j in range(out.shape[0]):
        out[j] = max(out[j], 0.0)
    return out


@njit(cache=True)
def _sigmoid(x):
    return 0.5 * (1.0 + tanh(0.5 * x))


@njit(cache=True)
def first_gates(encoding, net):
    """The first LSTM layer's input gates x @ w_ih + b for an encoding (kept per window and bin)."""
    w_ih, b = net[8], net[11]
    out = np.empty(w_ih.shape[1])
    affine(encoding, w_ih, b[0], out)
    return out


@njit(cache=True)
def first_step_logits(apex_features, gates_in, encoding, net, bins):
    """Logits of the model's first step from an apex (its three features), given the window's ``encoding`` and
    its first layer's input gates ``gates_in``: of every bin when ``bins`` is empty, else of those ``bins`` (the
    rest left at -inf)."""
    g0_w, g0_b, w_ih, w_hh, b, head_w, head_b = net[0], net[1], net[9], net[10], net[11], net[12], net[13]
    layers, hidden = w_hh.shape[0], w_hh.shape[1]
    state = np.empty(g0_w.shape[1])
    affine(apex_features, g0_w, g0_b, state)   # (h of every layer, then c of every layer)
    gates = np.empty(4 * hidden)
    x = np.empty(hidden)
    for layer in range(layers):
        h = state[layer * hidden:(layer + 1) * hidden]
        c = state[(layers + layer) * hidden:(layers + layer + 1) * hidden]
        affine(h, w_hh[layer], np.zeros(4 * hidden), gates)
        if layer == 0:
            for j in range(4 * hidden):
                gates[j] += gates_in[j]
        else:
            extra = np.empty(4 * hidden)
            affine(x, w_ih[layer - 1], b[layer], extra)
            for j in range(4 * hidden):
                gates[j] += extra[j]
        for j in range(hidden):
            cj = _sigmoid(gates[hidden + j]) * c[j] + _sigmoid(gates[j]) * tanh(gates[2 * hidden + j])
            x[j] = _sigmoid(gates[3 * hidden + j]) * tanh(cj)
    logits = np.empty(head_w.shape[1])
    if bins.shape[0] == 0:
        affine(x, head_w, head_b, logits)
        return logits
    logits[:] = -math.inf
    for b in bins:
        acc = 0.0
        for k in range(hidden):
            acc += x[k] * head_w[k, b]
        logits[b] = acc + head_b[b]
    return logits


@njit(cache=True)
def masked_softmax(logits, temperature, mask):
    """softmax(logits / temperature) with the bins where ``mask`` is True at probability 0 (those at -inf too);
    NaN everywhere when every bin is (numpy's 0/0: no candidate can be drawn)."""
    p = np.empty(logits.shape[0])
    top = -math.inf
    for j in range(p.shape[0]):
        p[j] = -math.inf if mask[j] else logits[j] / temperature
        top = max(top, p[j])
    total = 0.0
    for j in range(p.shape[0]):
        p[j] = math.exp(p[j] - top) if p[j] > -math.inf else 0.0
        total += p[j]
    if total == 0.0:
        p[:] = math.nan
        return p
    for j in range(p.shape[0]):
        p[j] /= total
    return p
