"""The learned correction of a robot's template (``drakeslip.apex_correction``) in compiled code: its forward pass
(``corrected_apex``) and the planners' hop (``template_step``), the step map plus the correction where the hopper's
parameter array carries one."""
from __future__ import annotations

import math

import numpy as np

from drakeslip.apex_correction import N_IN, N_OUT, N_PARAMS
from drakeslip.compiled import compiled
from drakeslip.dynamics import I_GRAVITY, I_LEG_LENGTH, height_at
from drakeslip.fast_step import OK, OUT_CODE, OUT_TD_X, OUT_X, OUT_XDOT, OUT_Z, STANCE_STEPS, step_one


@compiled()   # not inlined: compiled once, not into every search and check that may call it (seconds of first run)
def corrected_apex(p, before, ax, az, axdot, foot_x, foot_z, out):
    """Add the correction packed in ``p`` after its N_PARAMS parameters to the next apex in ``out`` (a
    ``step_one`` output) of the hop from apex (ax, az, axdot) that touched down at (foot_x, foot_z), after the hop
    ``before`` (see the module doc): ``drakeslip.apex_correction.correction_of`` in compiled code."""
    leg, g = p[I_LEG_LENGTH], p[I_GRAVITY]
    speed_unit = math.sqrt(g * leg)
    hidden = int(p[N_PARAMS])
    k = N_PARAMS + 1
    w1 = p[k:k + N_IN * hidden]
    k += N_IN * hidden
    b1 = p[k:k + hidden]
    k += hidden
    w2 = p[k:k + hidden * hidden]
    k += hidden * hidden
    b2 = p[k:k + hidden]
    k += hidden
    w3 = p[k:k + hidden * N_OUT]
    k += hidden * N_OUT
    b3 = p[k:k + N_OUT]
    k += N_OUT
    low, high = p[k:k + N_IN], p[k + N_IN:k + 2 * N_IN]
    mean, scale = p[k + 2 * N_IN:k + 3 * N_IN], p[k + 3 * N_IN:k + 4 * N_IN]
    out_scale = p[k + 4 * N_IN:k + 4 * N_IN + N_OUT]
    raw = np.empty(N_IN)
    raw[0], raw[1], raw[2] = (az - foot_z) / leg, axdot / speed_unit, (foot_x - ax) / leg
    if before[3] > 0.0:
        raw[3], raw[4], raw[5], raw[6] = before[0] / leg, before[1] / speed_unit, before[2] / leg, 1.0
    else:
        raw[3], raw[4], raw[5], raw[6] = raw[0], raw[1], raw[2], 0.0
    u = np.empty(N_IN)
    for i in range(N_IN):
        u[i] = (min(max(raw[i], low[i]), high[i]) - mean[i]) / scale[i]
    h = dense(dense(u, w1, b1, hidden, True), w2, b2, hidden, True)
    y = dense(h, w3, b3, N_OUT, False)
    out[OUT_X] += y[0] * out_scale[0] * leg
    out[OUT_Z] += y[1] * out_scale[1] * leg
    out[OUT_XDOT] += y[2] * out_scale[2] * speed_unit


@compiled(inline="always")
def dense(x, w, b, n_out, squash):
    """x @ w + b for ``w`` stored flat, (inputs, outputs) row by row, each output summed in input order from its
    bias; tanh'd where ``squash``."""
    y = np.empty(n_out)
    for j in range(n_out):
        acc = b[j]
        for i in range(x.shape[0]):
            acc += x[i] * w[i * n_out + j]
        y[j] = math.tanh(acc) if squash else acc
    return y


@compiled(inline="always")
def set_hop_before(row, apex, foothold, ground):
    """Write into ``row`` the hop from ``apex`` (x, z, xdot) that touched down at ``foothold`` on ``ground`` as the
    correction takes the hop before another (``before``: apex height above the foothold, speed, foothold ahead, 1).
    Element by element: an array assigned to a row compiles a shape check and its error message, seconds of a
    machine's first run."""
    row[0] = apex[1] - height_at(ground.heights, ground.x0, ground.cell, foothold)
    row[1] = apex[2]
    row[2] = foothold - apex[0]
    row[3] = 1.0


@compiled(inline="always")
def template_step(ax, az, axdot, leg_angle, p, ground, before, out):
    """One hop of the hopper ``p`` over ``ground`` as ``drakeslip.fast_step.step_one`` writes it into ``out``, its
    next apex corrected where ``p`` carries a correction (a ``RobotTemplate``'s, after the hop ``before``)."""
    step_one(ax, az, axdot, leg_angle, p, ground, np.int64(STANCE_STEPS), out)
    if out[OUT_CODE] == OK and p.shape[0] > N_PARAMS:
        foot_z = height_at(ground.heights, ground.x0, ground.cell, out[OUT_TD_X])
        corrected_apex(p, before, ax, az, axdot, out[OUT_TD_X], foot_z, out)
