"""The footstep model's forward pass for planning, compiled: the planners' one copy of ``FootstepModel``'s function
(planners/learned/model.py, the torch model it is trained as; tests/test_core.py and tests/test_lstm.py check the two
agree), in float64.

A step (``model_step``) encodes the window's heights and the previous step's distribution with the CNN, runs the
LSTM's layers from their state, and gives the head's logits over the window's bins; ``initial_state`` is the state
``g0`` gives for an apex. The sampled search's nodes (planners/core/sampled.py) ask for the first step from a node's
own apex with the bin under the body as the previous step, which ``first_gates`` and ``first_step_logits`` compute
faster: the encoding and the first layer's input gates depend only on the window and that bin, which nodes may
share, so they are computed once per (window, bin); each layer's recurrent product starts from the state ``g0``
gives, so it is taken from the apex directly (``from_apex``: the same sums in another order, equal but for
rounding); and the head only for the bins of the node's candidates where the search needs no more."""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from drakeslip.compiled import compiled


# exp on [-50, 0] (``exp_neg``): k = round(a / ln 2) and r = a - k ln 2 (ln 2 in two parts, as Cody and Waite),
# e^r by its Taylor polynomial of degree 13 (|r| <= ln 2 / 2: the first term left out is below 4e-18 of the sum),
# times 2^k written into the exponent's bits. Within an ulp of libm's exp; a loop over a layer's units that calls
# it vectorizes, which one calling libm's does not.
LOG2E = 1.4426950408889634
LN2_HI = 6.93147180369123816490e-01   # ln 2's leading bits: k * LN2_HI is exact for |k| < 2^20
LN2_LO = 1.90821492927058770002e-10
EXP_TAYLOR = tuple(1.0 / math.factorial(k) for k in range(14))
EXP_FLOOR = -50.0  # e^-50 = 2e-22: 1 - e and 1 + e round to 1, so tanh and the sigmoid are exact below it


@intrinsic
def _float_of_bits(typingctx, bits):
    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.DoubleType())

    return types.float64(types.int64), codegen


@compiled(fastmath={"contract"}, inline="always", error_model="numpy")
def exp_neg(a):
    """e^a for a <= 0 (a below EXP_FLOOR taken as EXP_FLOOR), within an ulp of ``math.exp``."""
    a = max(a, EXP_FLOOR)
    k = math.floor(a * LOG2E + 0.5)
    r = (a - k * LN2_HI) - k * LN2_LO
    c = EXP_TAYLOR
    p = ((((((((((((c[13] * r + c[12]) * r + c[11]) * r + c[10]) * r + c[9]) * r + c[8]) * r + c[7]) * r + c[6]) * r
                + c[5]) * r + c[4]) * r + c[3]) * r + c[2]) * r + c[1]) * r + c[0]
    return p * _float_of_bits((np.int64(k) + 1023) << 52)


@compiled(fastmath={"contract"}, inline="always", error_model="numpy")
def tanh(x):
    """tanh from one exp, within 3e-16 of libm's tanh (an absolute bound: near 0 the two differ in relative terms)."""
    e = exp_neg(-2.0 * abs(x))
    return math.copysign((1.0 - e) / (1.0 + e), x)


@compiled(fastmath={"contract"})
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


# A model's weights for compiled code, each layer's matrix stored (inputs, outputs): g0, the CNN's two convolutions
# (out, in, taps) and its linear layer, the first LSTM layer's input weights, the later layers' (layers - 1, H, 4H),
# every layer's recurrent weights (layers, H, 4H) and summed biases (layers, 4H), the head (H, bins), the sub-cells per
# cell; and for the first step from an apex, each layer's recurrent product of g0's state (layers, apex features, 4H)
# and of its bias (layers, 4H), and the head a bin per row (bins, H)
ModelArrays = namedtuple("ModelArrays", ["g0_w", "g0_b", "conv1_w", "conv1_b", "conv2_w", "conv2_b", "fc_w", "fc_b",
                                         "w_ih_first", "w_ih_rest", "w_hh", "b", "head_w", "head_b", "subcells",
                                         "from_apex", "from_apex_b", "head_rows"])


def model_arrays(model) -> ModelArrays:
    """A ``FootstepModel``'s weights as compiled code reads them."""
    w = {k: v.detach().double().cpu().numpy() for k, v in model.state_dict().items()}
    c = model.config
    layers, hidden = range(c.layers), c.hidden
    g0_w, g0_b = np.ascontiguousarray(w["g0.weight"].T), w["g0.bias"].copy()
    w_hh = [w[f"lstm.weight_hh_l{k}"].T for k in layers]
    from_apex = np.stack([g0_w[:, k * hidden:(k + 1) * hidden] @ w_hh[k] for k in layers])
    from_apex_b = np.stack([g0_b[k * hidden:(k + 1) * hidden] @ w_hh[k] for k in layers])
    return ModelArrays(g0_w, g0_b, w["cnn.0.weight"].copy(), w["cnn.0.bias"].copy(), w["cnn.2.weight"].copy(),
                       w["cnn.2.bias"].copy(), stored(w["cnn.5.weight"].T), w["cnn.5.bias"].copy(),
                       stored(w["lstm.weight_ih_l0"].T),
                       stored(np.stack([w[f"lstm.weight_ih_l{k}"].T for k in layers[1:]]).reshape(
                           c.layers - 1, c.hidden, 4 * c.hidden)),
                       stored(np.stack(w_hh)), np.stack([w[f"lstm.bias_ih_l{k}"] + w[f"lstm.bias_hh_l{k}"]
                                                         for k in layers]),
                       stored(w["head.weight"].T), w["head.bias"].copy(), int(c.subcells), from_apex, from_apex_b,
                       stored(w["head.weight"]))


@compiled(fastmath={"contract"})
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
        for i in range(n_in):
            for t in range(taps):
                wt = w[o, i, t]
                for c in range(n):
                    y[o, c] += wt * padded[i, t + c]
        for c in range(n):
            y[o, c] = max(y[o, c] + b[o], 0.0)
    return y


@compiled(fastmath={"contract"})
def _first_conv_relu(window, prev_bin, w, b, subcells):
    """``_conv_relu`` of the image (the window's heights; the previous step one-hot, a channel per sub-cell) without
    its zeros: the heights' taps, then the one weight each cell next to the previous step's cell meets. The zeros add
    nothing, so the sums are ``_conv_relu``'s."""
    n_out, taps, n = w.shape[0], w.shape[2], window.shape[0]
    half = taps // 2
    padded = np.zeros(n + 2 * half)
    padded[half:half + n] = window
    channel, cell = 1 + prev_bin % subcells, prev_bin // subcells
    y = np.zeros((n_out, n))
    for o in range(n_out):
        for t in range(taps):
            wt = w[o, 0, t]
            for c in range(n):
                y[o, c] += wt * padded[t + c]
        for c in range(max(cell - half, 0), min(cell + half + 1, n)):
            y[o, c] += w[o, channel, cell - c + half]
        for c in range(n):
            y[o, c] = max(y[o, c] + b[o], 0.0)
    return y


@compiled()
def encode(window, prev_bin, net):
    """The CNN's encoding (the LSTM's input) of the window's relative heights and a one-hot previous step at bin
    ``prev_bin``: ``encode_image``'s, without the image's zeros."""
    first = _first_conv_relu(window, prev_bin, net.conv1_w, net.conv1_b, net.subcells)
    return _fully_connected(_conv_relu(first, net.conv2_w, net.conv2_b).reshape(-1), net)


@compiled()
def encode_image(window, prev, net):
    """The CNN's encoding of the window's relative heights and a previous step's distribution ``prev`` over the
    window's bins (a channel per sub-cell)."""
    n, subcells = window.shape[0], net.subcells
    image = np.empty((1 + subcells, n))
    for c in range(n):
        image[0, c] = window[c]
        for k in range(subcells):
            image[1 + k, c] = prev[c * subcells + k]
    first = _conv_relu(image, net.conv1_w, net.conv1_b)
    return _fully_connected(_conv_relu(first, net.conv2_w, net.conv2_b).reshape(-1), net)


@compiled(inline="always")
def _fully_connected(features, net):
    """The CNN's last layer, with its ReLU."""
    out = np.empty(net.fc_w.shape[1])
    affine(features, net.fc_w, net.fc_b, out)
    for j in range(out.shape[0]):
        out[j] = max(out[j], 0.0)
    return out


@compiled(inline="always", error_model="numpy")
def _sigmoid(x):
    return 0.5 * (1.0 + tanh(0.5 * x))


@compiled()
def first_gates(encoding, net):
    """The first LSTM layer's input gates x @ w_ih + b for an encoding (kept per window and bin)."""
    w_ih, b = net.w_ih_first, net.b
    out = np.empty(w_ih.shape[1])
    affine(encoding, w_ih, b[0], out)
    return out


@compiled(fastmath={"contract"}, error_model="numpy")
def first_step_logits(apex_features, gates_in, net, bins):
    """Logits of the model's first step from an apex (its three features), given its window's first layer's input
    gates ``gates_in`` (``first_gates``): of every bin when ``bins`` is empty, else of those ``bins`` (the
    rest left at -inf)."""
    g0_w, g0_b, w_ih, from_apex, b, head_w, head_b = (net.g0_w, net.g0_b, net.w_ih_rest, net.from_apex, net.b,
                                                      net.head_w, net.head_b)
    from_apex_b, head_rows = net.from_apex_b, net.head_rows
    layers, hidden = from_apex.shape[0], b.shape[1] // 4
    cell = np.empty(layers * hidden)   # the initial c of every layer (g0's second half)
    affine(apex_features, g0_w[:, layers * hidden:], g0_b[layers * hidden:], cell)
    gates = np.empty(4 * hidden)
    extra = np.empty(4 * hidden)
    x = np.empty(hidden)
    for layer in range(layers):
        affine(apex_features, from_apex[layer], from_apex_b[layer], gates)
        if layer == 0:
            extra[:] = gates_in
        else:
            affine(x, w_ih[layer - 1], b[layer], extra)
        for j in range(4 * hidden):
            gates[j] += extra[j]
        c = cell[layer * hidden:(layer + 1) * hidden]
        for j in range(hidden):   # torch's gate order: input, forget, cell, output
            cj = _sigmoid(gates[hidden + j]) * c[j] + _sigmoid(gates[j]) * tanh(gates[2 * hidden + j])
            x[j] = _sigmoid(gates[3 * hidden + j]) * tanh(cj)
    logits = np.empty(head_w.shape[1])
    if bins.shape[0] == 0:
        affine(x, head_w, head_b, logits)
        return logits
    logits[:] = -math.inf
    for j in bins:
        row = head_rows[j]
        acc = 0.0
        for k in range(hidden):
            acc += x[k] * row[k]
        logits[j] = acc + head_b[j]
    return logits


@compiled()
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


@compiled(fastmath={"contract"}, error_model="numpy")
def initial_state(apex_features, net):
    """The LSTM's state (h, c), each (layers, H), that ``g0`` gives for an apex's three features."""
    layers, hidden = net.b.shape[0], net.b.shape[1] // 4
    hc = np.empty(2 * layers * hidden)
    affine(apex_features, net.g0_w, net.g0_b, hc)
    return hc[:layers * hidden].copy().reshape(layers, hidden), hc[layers * hidden:].copy().reshape(layers, hidden)


@compiled(fastmath={"contract"}, error_model="numpy")
def model_step(window, prev, h, c, net):
    """One step of the model: the logits over the window's bins of the step after ``prev`` (a distribution over
    them), and the LSTM's state after it, from the state (``h``, ``c``)."""
    layers, hidden = net.b.shape[0], net.b.shape[1] // 4
    x = encode_image(window, prev, net)
    h_after, c_after = np.empty((layers, hidden)), np.empty((layers, hidden))
    gates, recurrent = np.empty(4 * hidden), np.empty(4 * hidden)
    for layer in range(layers):
        if layer == 0:
            affine(x, net.w_ih_first, net.b[layer], gates)
        else:
            affine(x, net.w_ih_rest[layer - 1], net.b[layer], gates)
        affine(h[layer], net.w_hh[layer], np.zeros(4 * hidden), recurrent)
        x = np.empty(hidden)
        for j in range(hidden):   # torch's gate order: input, forget, cell, output
            g = gates[j] + recurrent[j], gates[hidden + j] + recurrent[hidden + j]
            cell = _sigmoid(g[1]) * c[layer, j] + _sigmoid(g[0]) * tanh(gates[2 * hidden + j]
                                                                           + recurrent[2 * hidden + j])
            c_after[layer, j] = cell
            x[j] = h_after[layer, j] = _sigmoid(gates[3 * hidden + j] + recurrent[3 * hidden + j]) * tanh(cell)
    logits = np.empty(net.head_w.shape[1])
    affine(x, net.head_w, net.head_b, logits)
    return logits, h_after, c_after
