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


@compiled(inline="always")
def corrected_apex(p, before, ax, az, axdot, foot_x, foot_z, out):
    """Add the correction packed in ``p`` after its N_PARAMS parameters to the next apex in ``out`` (a
    ``step_one`` output) of the hop from apex (ax, az, axdot) that touched down at (foot_x, foot_z), after the hop
    ``before`` (see the module doc): ``ApexCorrection.__call__`` in compiled code."""
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
    low, high, mean, scale = p[k:k + N_IN], p[k + N_IN:k + 2 * N_IN], p[k + 2 * N_IN:k + 3 * N_IN], p[
        k + 3 * N_IN:k + 4 * N_IN]
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
    h1 = np.empty(hidden)
    for j in range(hidden):
        acc = b1[j]
        for i in range(N_IN):
            acc += u[i] * w1[i * hidden + j]
        h1[j] = math.tanh(acc)
    h2 = np.empty(hidden)
    for j in range(hidden):
        acc = b2[j]
        for i in range(hidden):
            acc += h1[i] * w2[i * hidden + j]
        h2[j] = math.tanh(acc)
    for o in range(N_OUT):
        acc = b3[o]
        for i in range(hidden):
            acc += h2[i] * w3[i * N_OUT + o]
        unit = speed_unit if o == 2 else leg
        col = OUT_X if o == 0 else (OUT_Z if o == 1 else OUT_XDOT)
        out[col] += acc * out_scale[o] * unit


@compiled(inline="always")
def template_step(ax, az, axdot, leg_angle, p, ground, before, out):
    """One hop of the hopper ``p`` over ``ground`` as ``drakeslip.fast_step.step_one`` writes it into ``out``, its
    next apex corrected where ``p`` carries a correction (a ``RobotTemplate``'s, after the hop ``before``)."""
    step_one(ax, az, axdot, leg_angle, p, ground, np.int64(STANCE_STEPS), out)
    if out[OUT_CODE] == OK and p.shape[0] > N_PARAMS:
        foot_z = height_at(ground.heights, ground.x0, ground.cell, out[OUT_TD_X])
        corrected_apex(p, before, ax, az, axdot, out[OUT_TD_X], foot_z, out)
