"""The step-length controller for compiled code: ``aim_rows`` is ``StepLengthController.leg_angles`` to the bit,
callable from the planning core (planners/core), which aims every batch of candidate footholds with it.

To be the controller's to the bit, ``aim_rows`` multiplies by numpy's BLAS routine (numba's ``np.dot`` calls the
same one) and takes numpy's tanh (its vectorized tanh rounds otherwise than the C library's) in one call per layer;
the polish is the controller's compiled one (``drakeslip.leg_aim.polish_one``)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit, objmode

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


def _numpy_tanh(x):
    return np.tanh(x)


@njit(cache=True)
def _tanh_rows(x):
    """numpy's tanh of a matrix (its vectorized tanh rounds otherwise than the C library's, which compiled code
    calls): one call per layer, so the batch's angles are numpy's."""
    with objmode(y="float64[:, ::1]"):
        y = _numpy_tanh(x)
    return y


@njit(cache=True)
def aim_rows(apexes, footholds, grounds, net):
    """``StepLengthController.leg_angles`` for one apex row (x, z, xdot) per foothold, to the bit: the same features,
    the network's products by the same BLAS routine numpy calls (``np.dot``), numpy's tanh, the same polish."""
    w_in, b_in, w_hidden, b_hidden, w_head, b_head, mean, std, scale, max_angle, leg, gravity, refine = net
    n = footholds.shape[0]
    feats = np.empty((n, 3))
    for i in range(n):
        feats[i, 0] = apexes[i, 2]
        feats[i, 1] = apexes[i, 1] - grounds[i]
        feats[i, 2] = footholds[i] - apexes[i, 0]
    x = (feats / scale - mean) / std
    x = _tanh_rows(np.dot(x, w_in) + b_in)
    for layer in range(w_hidden.shape[0]):
        x = _tanh_rows(np.dot(x, w_hidden[layer]) + b_hidden[layer])
    theta = np.empty(n)
    head = np.dot(x, w_head.reshape(-1, 1))
    for i in range(n):
        theta[i] = min(max((head[i, 0] + b_head) * max_angle, -max_angle), max_angle)
        if refine:
            theta[i] = polish_one(feats[i, 0], feats[i, 1], feats[i, 2], theta[i], leg, gravity, max_angle)
    return theta
