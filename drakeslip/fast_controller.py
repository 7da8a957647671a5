"""The step-length controller's network and polish, compiled: ``StepLengthController.leg_angles`` for one apex and
one foothold at a time, callable from other compiled code (the planning core aims every candidate foothold with
it).

The network's layers are the controller's weights (``ControllerArrays``). Each product is summed in input order
(``affine``), so an angle is the same on every machine (a BLAS kernel's order of summation depends on the
processor), and
``StepLengthController.leg_angles`` runs these same functions, so a planner's angles are the controller's to the
bit."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from drakeslip.leg_aim import polish_one


@dataclass(frozen=True)
class ControllerArrays:
    """A controller's network as arrays for compiled code: input layer ``w_in`` (3, H) and ``b_in`` (H,), hidden
    layers ``w_hidden`` (L-1, H, H) and ``b_hidden`` (L-1, H), head ``w_head`` (H,) and ``b_head``; the feature
    statistics ``mean``, ``std`` and the hopper's ``scale`` (ones for the trained hopper), ``max_angle``, and the
    aimed hopper's ``leg_length``, ``gravity``; ``refine``: polish with Newton steps."""

    w_in: np.ndarray
    b_in: np.ndarray
    w_hidden: np.ndarray
    b_hidden: np.ndarray
    w_head: np.ndarray
    b_head: float
    mean: np.ndarray
    std: np.ndarray
    scale: np.ndarray
    max_angle: float
    leg_length: float
    gravity: float
    refine: bool

    def astuple(self) -> tuple:
        return (self.w_in, self.b_in, self.w_hidden, self.b_hidden, self.w_head, self.b_head, self.mean, self.std,
                self.scale, self.max_angle, self.leg_length, self.gravity, self.refine)


@njit(cache=True)
def tanh(x):
    """tanh from one exp (a quarter of libm's tanh's cost), within 3e-16 of it."""
    e = math.exp(-2.0 * abs(x))
    return math.copysign((1.0 - e) / (1.0 + e), x)


# tanh(x) ~ x P(x^2) / Q(x^2) on |x| <= TANH_CLAMP (Eigen's rational approximation of tanh, float32-accurate)
TANH_P = (4.89352455891786e-03, 6.37261928875436e-04, 1.48572235717979e-05, 5.12229709037114e-08,
          -8.60467152213735e-11, 2.00018790482477e-13, -2.76076847742355e-16)
TANH_Q = (4.89352518554385e-03, 2.26843463243900e-03, 1.18534705686654e-04, 1.19825839466702e-06)
TANH_CLAMP = 7.90531110763549805


@njit(cache=True)
def rational_tanh(x):
    """tanh to float32's precision (within 3e-7) with no library call, so a layer's activations vectorize: the
    controller's network was trained in float32, and its angle only starts the Newton polish."""
    x = min(max(x, -TANH_CLAMP), TANH_CLAMP)
    x2 = x * x
    p = TANH_P[6]
    for k in range(5, -1, -1):
        p = p * x2 + TANH_P[k]
    q = TANH_Q[3]
    for k in range(2, -1, -1):
        q = q * x2 + TANH_Q[k]
    return x * p / q


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


@njit(cache=True)
def _dense_tanh(x, w, b, out):
    """out = tanh(x @ w + b)."""
    affine(x, w, b, out)
    for j in range(out.shape[0]):
        out[j] = rational_tanh(out[j])


@njit(cache=True, fastmath={"contract"})
def _dot(x, w):
    acc = 0.0
    for k in range(w.shape[0]):
        acc += x[k] * w[k]
    return acc


@njit(cache=True)
def network_angle(speed, drop, offset, net):
    """The network's leg angle (clipped to its max_angle) for one (speed, drop, foothold offset)."""
    w_in, b_in, w_hidden, b_hidden, w_head, b_head, mean, std, scale, max_angle = net[:10]
    h = w_in.shape[1]
    x = np.empty(3)
    x[0] = (speed / scale[0] - mean[0]) / std[0]
    x[1] = (drop / scale[1] - mean[1]) / std[1]
    x[2] = (offset / scale[2] - mean[2]) / std[2]
    a, b = np.empty(h), np.empty(h)
    _dense_tanh(x, w_in, b_in, a)
    for layer in range(w_hidden.shape[0]):
        _dense_tanh(a, w_hidden[layer], b_hidden[layer], b)
        a, b = b, a
    theta = (_dot(a, w_head) + b_head) * max_angle
    return min(max(theta, -max_angle), max_angle)


@njit(cache=True)
def aim(x, z, xdot, foothold, ground, net):
    """The controller's leg angle from apex (x, z, xdot) to ``foothold``, whose ground height is ``ground``."""
    speed, drop, offset = xdot, z - ground, foothold - x
    theta = network_angle(speed, drop, offset, net)
    if net[12]:
        theta = polish_one(speed, drop, offset, theta, net[10], net[11], net[9])
    return theta


@njit(cache=True)
def network_angles(feats, net):
    """``network_angle`` for each row (speed, drop, foothold offset) of ``feats`` (N, 3)."""
    out = np.empty(feats.shape[0])
    for i in range(feats.shape[0]):
        out[i] = network_angle(feats[i, 0], feats[i, 1], feats[i, 2], net)
    return out
