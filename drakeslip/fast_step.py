"""Compiled apex-to-apex step map: analytic flight, RK4 stance with localized events.

Flight is a parabola, so flight events (touchdown, foot or body meeting a top surface or a vertical face)
are found exactly by walking the cells the point crosses. Stance has no closed form: it is integrated with
fixed-step RK4 (``stance_steps`` steps per half natural period) using ``dynamics.stance_derivatives``, and a
guard that changes sign inside a step is localized by bisection on the step's cubic Hermite interpolant.
"""
from __future__ import annotations

import math

import numpy as np
from numba import prange

from drakeslip.compiled import compiled
from drakeslip.dynamics import (FACE_TOLERANCE, I_GRAVITY, body_clearance, cell_index, classify_foot_contact,
                       foot_clearance, foot_position, friction_margin, leg_extension, leg_rate, stance_derivatives,
                       stroke_left)

OK, BODY_COLLISION, FOOT_COLLISION, SLIP, BOTTOM_OUT, TRIP, STALL = 0, 1, 2, 3, 4, 5, 6
TOP, FACE = 0, 1
STANCE_STEPS = 60  # RK4 steps per half natural period pi/omega (energy error ~1e-8 relative)
# Compiled callers pass it as np.int64(STANCE_STEPS): numba types a global int as a literal, and a literal argument
# compiles a specialization of step_one of its own (seconds of compile time, the same machine code).
MAX_STANCE_PERIODS = 10  # a stance longer than this many half periods is a STALL (never happens physically)
BISECTIONS = 40
# Output columns of the batched kernel.
OUT_CODE, OUT_TD_X, OUT_X, OUT_Z, OUT_XDOT, OUT_ZDOT, OUT_TIME, OUT_WORK = range(8)
N_OUT = 8


@compiled()
def first_contact(px, pz, vx, vz, g, t_max, ground):
    """First time a point on the parabola (px + vx t, pz + vz t - g t^2 / 2) meets the ``ground``
    (``drakeslip.terrain.Ground``), up to t_max. Returns (t, kind, cell index) with kind TOP or FACE, or (inf, -1,
    -1) if none."""
    heights, x0, cell = ground.heights, ground.x0, ground.cell
    n = heights.shape[0]
    i = cell_index(px, x0, cell, n)
    if pz <= heights[i]:
        return 0.0, TOP, i
    while True:
        h = heights[i]
        if vx > 0.0 and i < n - 1:
            t_exit = (x0 + (i + 1) * cell - px) / vx
        elif vx < 0.0 and i > 0:
            t_exit = (x0 + i * cell - px) / vx
        else:
            t_exit = math.inf
        t_land = (vz + math.sqrt(max(vz * vz + 2.0 * g * (pz - h), 0.0))) / g
        if t_land <= t_exit and t_land <= t_max:
            return t_land, TOP, i
        if t_exit >= t_max:
            return math.inf, -1, -1
        i += 1 if vx > 0.0 else -1
        z_edge = pz + vz * t_exit - 0.5 * g * t_exit * t_exit
        if z_edge < heights[i] - FACE_TOLERANCE:
            return t_exit, FACE, i
        if z_edge < heights[i]:
            return t_exit, TOP, i  # the corner of the new cell


@compiled()
def rk4_step(s, fx, fz, h, p):
    """One RK4 step of length h of the stance state s = (x, z, xdot, zdot) on a foot pinned at (fx, fz)."""
    k1 = stance_derivatives(s[0], s[1], s[2], s[3], fx, fz, p)
    k2 = stance_derivatives(s[0] + 0.5 * h * k1[0], s[1] + 0.5 * h * k1[1], s[2] + 0.5 * h * k1[2],
                            s[3] + 0.5 * h * k1[3], fx, fz, p)
    k3 = stance_derivatives(s[0] + 0.5 * h * k2[0], s[1] + 0.5 * h * k2[1], s[2] + 0.5 * h * k2[2],
                            s[3] + 0.5 * h * k2[3], fx, fz, p)
    k4 = stance_derivatives(s[0] + h * k3[0], s[1] + h * k3[1], s[2] + h * k3[2], s[3] + h * k3[3], fx, fz, p)
    c = h / 6.0
    return (s[0] + c * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]),
            s[1] + c * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]),
            s[2] + c * (k1[2] + 2.0 * k2[2] + 2.0 * k3[2] + k4[2]),
            s[3] + c * (k1[3] + 2.0 * k2[3] + 2.0 * k3[3] + k4[3]))


@compiled()
def _hermite(s0, d0, s1, d1, h, tau):
    """Cubic Hermite interpolant of the state over one step, at tau in [0, h]."""
    u = tau / h
    a = 2 * u ** 3 - 3 * u ** 2 + 1
    b = (u ** 3 - 2 * u ** 2 + u) * h
    c = -2 * u ** 3 + 3 * u ** 2
    e = (u ** 3 - u ** 2) * h
    return (a * s0[0] + b * d0[0] + c * s1[0] + e * d1[0], a * s0[1] + b * d0[1] + c * s1[1] + e * d1[1],
            a * s0[2] + b * d0[2] + c * s1[2] + e * d1[2], a * s0[3] + b * d0[3] + c * s1[3] + e * d1[3])


N_STANCE_GUARDS = 5
_STANCE_EVENT_CODE = (OK, BODY_COLLISION, SLIP, BOTTOM_OUT, STALL)


@compiled()
def _stance_guard(k, s, fx, fz, p, ground):
    """Guard k that ends stance, 'event when <= 0': liftoff (negated extension), BODY_COLLISION, SLIP,
    BOTTOM_OUT, STALL (forward velocity)."""
    if k == 0:
        return -leg_extension(s[0], s[1], fx, fz, p)
    if k == 1:
        return body_clearance(s[0], s[1], ground.heights, ground.x0, ground.cell)
    if k == 2:
        return friction_margin(s[0], s[1], fx, fz, p)
    if k == 3:
        return stroke_left(s[0], s[1], fx, fz, p)
    return s[2]


@compiled()
def _stance(s, fx, fz, p, ground, stance_steps):
    """Integrate stance from touchdown. Returns (code, state at the event, elapsed time, RK4 steps);
    code OK means liftoff."""
    h = math.pi / math.sqrt(p[2] / p[0]) / stance_steps
    t = 0.0
    for n_step in range(MAX_STANCE_PERIODS * stance_steps):
        s1 = rk4_step(s, fx, fz, h, p)
        fired = False
        for k in range(N_STANCE_GUARDS):
            if _stance_guard(k, s1, fx, fz, p, ground) <= 0.0:
                fired = True
        if fired:
            d0 = stance_derivatives(s[0], s[1], s[2], s[3], fx, fz, p)
            d1 = stance_derivatives(s1[0], s1[1], s1[2], s1[3], fx, fz, p)
            best_tau = math.inf
            best_k = -1
            for k in range(N_STANCE_GUARDS):
                if _stance_guard(k, s1, fx, fz, p, ground) > 0.0:
                    continue
                lo, hi = 0.0, h  # guard k is positive at the start of the step, <= 0 at its end
                for _ in range(BISECTIONS):
                    mid = 0.5 * (lo + hi)
                    if _stance_guard(k, _hermite(s, d0, s1, d1, h, mid), fx, fz, p, ground) <= 0.0:
                        hi = mid
                    else:
                        lo = mid
                if hi < best_tau:
                    best_tau = hi
                    best_k = k
            return _STANCE_EVENT_CODE[best_k], _hermite(s, d0, s1, d1, h, best_tau), t + best_tau, n_step + 1
        s = s1
        t += h
    return STALL, s, t, MAX_STANCE_PERIODS * stance_steps


@compiled(inline="always")
def _descend(ax, az, axdot, leg_angle, p, ground, out):
    """From the apex to touchdown: the leg swung to ``leg_angle``, the body and the foot fall until one meets the
    ground. Returns the touchdown's foot (x, z) and the body's state there, (x, z, zdot, time), with ``out``'s code
    OK, or a failure's code in ``out`` (the state there in ``out``)."""
    g = p[I_GRAVITY]
    out[OUT_CODE] = OK
    if body_clearance(ax, az, ground.heights, ground.x0, ground.cell) <= 0.0:
        out[OUT_CODE] = BODY_COLLISION
        return 0.0, 0.0, ax, az, 0.0, 0.0
    if axdot <= 0.0:
        out[OUT_CODE] = STALL
        return 0.0, 0.0, ax, az, 0.0, 0.0
    # Apex: swing the leg to the commanded angle; the foot must end above the terrain.
    if foot_clearance(ax, az, leg_angle, p, ground.heights, ground.x0, ground.cell) <= 0.0:
        out[OUT_CODE] = TRIP
        return 0.0, 0.0, ax, az, 0.0, 0.0
    # Descent with the leg extended: whichever of foot and body meets the terrain first.
    fx0, fz0 = foot_position(ax, az, leg_angle, p)
    t_foot, kind, i_foot = first_contact(fx0, fz0, axdot, 0.0, g, math.inf, ground)
    t_body, _, _ = first_contact(ax, az, axdot, 0.0, g, t_foot, ground)
    t = min(t_foot, t_body)
    x, z, zdot = ax + axdot * t, az - 0.5 * g * t * t, -g * t
    out[OUT_X], out[OUT_Z], out[OUT_ZDOT], out[OUT_TIME] = x, z, zdot, t
    foot_x, foot_z = fx0 + axdot * t, fz0 - 0.5 * g * t * t
    if t_body < t_foot:
        out[OUT_CODE] = BODY_COLLISION
    elif kind == FACE or classify_foot_contact(foot_z, ground.heights[i_foot], ground.ditch_height) != OK:
        out[OUT_CODE] = FOOT_COLLISION
    return foot_x, foot_z, x, z, zdot, t


@compiled()
def step_one(ax, az, axdot, leg_angle, p, ground, stance_steps, out):
    """One apex-to-apex step over ``ground`` (``drakeslip.terrain.Ground``); writes (code, touchdown_x, x, z, xdot,
    zdot, time, work) into ``out``. On success (x, z, xdot) is the next apex; on failure (x, z, xdot, zdot) is the
    state at the failure."""
    g = p[I_GRAVITY]
    out[OUT_TD_X] = math.nan
    out[OUT_WORK] = 0.0
    out[OUT_X], out[OUT_Z], out[OUT_XDOT], out[OUT_ZDOT], out[OUT_TIME] = ax, az, axdot, 0.0, 0.0
    foot_x, foot_z, x, z, zdot, t = _descend(ax, az, axdot, leg_angle, p, ground, out)
    if out[OUT_CODE] != OK:
        return
    out[OUT_TD_X] = foot_x
    # Touchdown: the foot is pinned; the leg must be able to load and start inside the friction cone.
    if friction_margin(x, z, foot_x, foot_z, p) < 0.0:
        out[OUT_CODE] = SLIP
        return
    if leg_rate(x, z, axdot, zdot, foot_x, foot_z) >= 0.0:
        out[OUT_CODE] = STALL
        return
    s = (x, z, axdot, zdot)
    code, s, t_stance, work = _stance(s, foot_x, foot_z, p, ground, stance_steps)
    t += t_stance
    out[OUT_WORK] = work
    out[OUT_X], out[OUT_Z], out[OUT_XDOT], out[OUT_ZDOT], out[OUT_TIME] = s[0], s[1], s[2], s[3], t
    if code != OK:
        out[OUT_CODE] = code
        return
    # Liftoff: ballistic ascent to the next apex, leg retracted.
    if s[3] <= 0.0 or s[2] <= 0.0:
        out[OUT_CODE] = STALL
        return
    t_up = s[3] / g
    t_hit, _, _ = first_contact(s[0], s[1], s[2], s[3], g, t_up, ground)
    if t_hit < t_up:
        t_up = t_hit
        out[OUT_CODE] = BODY_COLLISION
    else:
        out[OUT_CODE] = OK
    out[OUT_X] = s[0] + s[2] * t_up
    out[OUT_Z] = s[1] + s[3] * t_up - 0.5 * g * t_up * t_up
    out[OUT_ZDOT] = s[3] - g * t_up
    out[OUT_TIME] = t + t_up


@compiled(parallel=False)
def step_many(ax, az, axdot, leg_angles, p, ground, stance_steps):
    """Vectorized step over arrays of apex states and leg angles (all the same length)."""
    n = leg_angles.shape[0]
    out = np.empty((n, N_OUT))
    for i in range(n):
        step_one(ax[i], az[i], axdot[i], leg_angles[i], p, ground, stance_steps, out[i])
    return out


@compiled(parallel=True)
def step_many_parallel(ax, az, axdot, leg_angles, p, ground, stance_steps):
    """``step_many`` spread over all cores, for large batches (dataset and controller training grids)."""
    n = leg_angles.shape[0]
    out = np.empty((n, N_OUT))
    for i in prange(n):
        step_one(ax[i], az[i], axdot[i], leg_angles[i], p, ground, stance_steps, out[i])
    return out
