"""The spatial SLIP's compiled apex-to-apex step map (``drakeslip.fast_step`` in three dimensions): analytic flight
over the height map's cells, RK4 stance with localized events.

Flight is a parabola over a straight horizontal path, so flight events (touchdown, foot or body meeting a top or a
face) are found exactly by walking the cells the path crosses, in x and in y. Stance is integrated with fixed-step
RK4 (``stance_steps`` per half natural period) on ``drakeslip.spatial.dynamics.stance_derivatives``; a guard that
changes sign inside a step is localized by bisection on the step's cubic Hermite interpolant. Along a path with
no lateral motion on a map that does not vary across it, every number is the planar map's.
"""
from __future__ import annotations

import math

import numpy as np

from drakeslip.compiled import compiled
from drakeslip.dynamics import FACE_TOLERANCE, I_GRAVITY, I_MASS, I_STIFFNESS, classify_foot_contact
from drakeslip.fast_step import BISECTIONS, BODY_COLLISION, FACE, FOOT_COLLISION, MAX_STANCE_PERIODS, OK, SLIP, \
    STALL, TOP, TRIP, BOTTOM_OUT
from drakeslip.spatial.dynamics import body_clearance, cell_of, foot_clearance, foot_position, friction_margin, \
    heading_of, leg_extension, leg_rate, progress, stance_derivatives, stroke_left

# Output columns of the batched kernel.
OUT_CODE, OUT_TD_X, OUT_TD_Y, OUT_TD_Z, OUT_X, OUT_Y, OUT_Z, OUT_XDOT, OUT_YDOT, OUT_ZDOT, OUT_TIME, OUT_WORK = \
    range(12)
N_OUT = 12


# many parameters: one axis's position, speed, cell index and count, origin and cell size, as scalars
@compiled(inline="always")
def cell_exit(position, velocity, index, count, origin, cell):
    """When a point at ``position`` moving at ``velocity`` along one axis leaves cell ``index`` of ``count`` (inf: it
    stays, or leaves past the map's last cell, beyond which the map extends flat)."""
    if velocity > 0.0 and index < count - 1:
        return (origin + (index + 1) * cell - position) / velocity
    if velocity < 0.0 and index > 0:
        return (origin + index * cell - position) / velocity
    return math.inf


# many parameters: a point and its velocity, three coordinates each, as scalars compiled code passes in registers
@compiled()
def first_contact(px, py, pz, vx, vy, vz, g, t_max, ground):
    """First time a point on the parabola (p + v t - g t^2 / 2 z) meets the ground, up to t_max: (t, kind, row,
    column) with kind TOP or FACE, or (inf, -1, -1, -1) if none."""
    heights, x0, y0, cell = ground.heights, ground.x0, ground.y0, ground.cell
    ny, nx = heights.shape
    j, i = cell_of(px, py, ground)
    if pz <= heights[j, i]:
        return 0.0, TOP, j, i
    while True:
        h = heights[j, i]
        t_x, t_y = cell_exit(px, vx, i, nx, x0, cell), cell_exit(py, vy, j, ny, y0, cell)
        t_exit = min(t_x, t_y)
        t_land = (vz + math.sqrt(max(vz * vz + 2.0 * g * (pz - h), 0.0))) / g
        if t_land <= t_exit and t_land <= t_max:
            return t_land, TOP, j, i
        if t_exit >= t_max:
            return math.inf, -1, -1, -1
        if t_x <= t_y:
            i += 1 if vx > 0.0 else -1
        if t_y <= t_x:
            j += 1 if vy > 0.0 else -1
        z_edge = pz + vz * t_exit - 0.5 * g * t_exit * t_exit
        if z_edge < heights[j, i] - FACE_TOLERANCE:
            return t_exit, FACE, j, i
        if z_edge < heights[j, i]:
            return t_exit, TOP, j, i  # the corner of the new cell


@compiled()
def rk4_step(s, fx, fy, fz, h, p):
    """One RK4 step of length h of the stance state s = (x, y, z, xdot, ydot, zdot) on a foot pinned at f."""
    k1 = stance_derivatives(s, fx, fy, fz, p)
    k2 = stance_derivatives(along(s, k1, 0.5 * h), fx, fy, fz, p)
    k3 = stance_derivatives(along(s, k2, 0.5 * h), fx, fy, fz, p)
    k4 = stance_derivatives(along(s, k3, h), fx, fy, fz, p)
    c = h / 6.0
    return (s[0] + c * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]),
            s[1] + c * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]),
            s[2] + c * (k1[2] + 2.0 * k2[2] + 2.0 * k3[2] + k4[2]),
            s[3] + c * (k1[3] + 2.0 * k2[3] + 2.0 * k3[3] + k4[3]),
            s[4] + c * (k1[4] + 2.0 * k2[4] + 2.0 * k3[4] + k4[4]),
            s[5] + c * (k1[5] + 2.0 * k2[5] + 2.0 * k3[5] + k4[5]))


@compiled(inline="always")
def along(s, d, h):
    return s[0] + h * d[0], s[1] + h * d[1], s[2] + h * d[2], s[3] + h * d[3], s[4] + h * d[4], s[5] + h * d[5]


@compiled()
def hermite(s0, d0, s1, d1, h, tau):
    """Cubic Hermite interpolant of the stance state over one step, at tau in [0, h]."""
    u = tau / h
    a = 2 * u ** 3 - 3 * u ** 2 + 1
    b = (u ** 3 - 2 * u ** 2 + u) * h
    c = -2 * u ** 3 + 3 * u ** 2
    e = (u ** 3 - u ** 2) * h
    return (a * s0[0] + b * d0[0] + c * s1[0] + e * d1[0], a * s0[1] + b * d0[1] + c * s1[1] + e * d1[1],
            a * s0[2] + b * d0[2] + c * s1[2] + e * d1[2], a * s0[3] + b * d0[3] + c * s1[3] + e * d1[3],
            a * s0[4] + b * d0[4] + c * s1[4] + e * d1[4], a * s0[5] + b * d0[5] + c * s1[5] + e * d1[5])


N_STANCE_GUARDS = 5
STANCE_EVENT_CODE = (OK, BODY_COLLISION, SLIP, BOTTOM_OUT, STALL)


@compiled()
def stance_guard(k, s, foot, heading, p, ground):
    """Guard k that ends stance, 'event when <= 0': liftoff (negated extension), BODY_COLLISION, SLIP, BOTTOM_OUT,
    STALL (progress along the heading)."""
    fx, fy, fz = foot
    if k == 0:
        return -leg_extension(s[0], s[1], s[2], fx, fy, fz, p)
    if k == 1:
        return body_clearance(s[0], s[1], s[2], ground)
    if k == 2:
        return friction_margin(s[0], s[1], s[2], fx, fy, fz, p)
    if k == 3:
        return stroke_left(s[0], s[1], s[2], fx, fy, fz, p)
    return progress(s[3], s[4], heading[0], heading[1])


@compiled()
def stance(s, foot, heading, p, ground, stance_steps):
    """Integrate stance from touchdown: (code, state at the event, elapsed time, RK4 steps); OK means liftoff."""
    fx, fy, fz = foot
    h = math.pi / math.sqrt(p[I_STIFFNESS] / p[I_MASS]) / stance_steps
    t = 0.0
    for n_step in range(MAX_STANCE_PERIODS * stance_steps):
        s1 = rk4_step(s, fx, fy, fz, h, p)
        fired = False
        for k in range(N_STANCE_GUARDS):
            if stance_guard(k, s1, foot, heading, p, ground) <= 0.0:
                fired = True
        if fired:
            d0 = stance_derivatives(s, fx, fy, fz, p)
            d1 = stance_derivatives(s1, fx, fy, fz, p)
            best_tau = math.inf
            best_k = -1
            for k in range(N_STANCE_GUARDS):
                if stance_guard(k, s1, foot, heading, p, ground) > 0.0:
                    continue
                lo, hi = 0.0, h  # guard k is positive at the start of the step, <= 0 at its end
                for _ in range(BISECTIONS):
                    mid = 0.5 * (lo + hi)
                    if stance_guard(k, hermite(s, d0, s1, d1, h, mid), foot, heading, p, ground) <= 0.0:
                        hi = mid
                    else:
                        lo = mid
                if hi < best_tau:
                    best_tau = hi
                    best_k = k
            return STANCE_EVENT_CODE[best_k], hermite(s, d0, s1, d1, h, best_tau), t + best_tau, n_step + 1
        s = s1
        t += h
    return STALL, s, t, MAX_STANCE_PERIODS * stance_steps


@compiled(inline="always")
def write_state(out, s, t):
    out[OUT_X], out[OUT_Y], out[OUT_Z] = s[0], s[1], s[2]
    out[OUT_XDOT], out[OUT_YDOT], out[OUT_ZDOT], out[OUT_TIME] = s[3], s[4], s[5], t


@compiled(inline="always")
def descend(a, pitch, roll, p, ground, out):
    """From the apex ``a`` = (x, y, z, xdot, ydot) to touchdown: the leg swung to (pitch, roll), body and foot fall
    until one meets the ground. Returns the foot and the body's state there, with ``out``'s code OK, or a failure's
    code in ``out`` (the state there in ``out``)."""
    g = p[I_GRAVITY]
    ax, ay, az, axdot, aydot = a
    out[OUT_CODE] = OK
    none = (0.0, 0.0, 0.0), (ax, ay, az, axdot, aydot, 0.0), 0.0
    if body_clearance(ax, ay, az, ground) <= 0.0:
        out[OUT_CODE] = BODY_COLLISION
        return none
    if axdot * axdot + aydot * aydot <= 0.0:
        out[OUT_CODE] = STALL
        return none
    if foot_clearance(ax, ay, az, pitch, roll, p, ground) <= 0.0:
        out[OUT_CODE] = TRIP
        return none
    fx0, fy0, fz0 = foot_position(ax, ay, az, pitch, roll, p)
    t_foot, kind, j_foot, i_foot = first_contact(fx0, fy0, fz0, axdot, aydot, 0.0, g, math.inf, ground)
    t_body, _, _, _ = first_contact(ax, ay, az, axdot, aydot, 0.0, g, t_foot, ground)
    t = min(t_foot, t_body)
    s = (ax + axdot * t, ay + aydot * t, az - 0.5 * g * t * t, axdot, aydot, -g * t)
    write_state(out, s, t)
    foot = (fx0 + axdot * t, fy0 + aydot * t, fz0 - 0.5 * g * t * t)
    if t_body < t_foot:
        out[OUT_CODE] = BODY_COLLISION
    elif kind == FACE or classify_foot_contact(foot[2], ground.heights[j_foot, i_foot], ground.ditch_height) != OK:
        out[OUT_CODE] = FOOT_COLLISION
    return foot, s, t


@compiled()
def step_one(apex, pitch, roll, p, ground, stance_steps, out):
    """One apex-to-apex step from ``apex`` (x, y, z, xdot, ydot); writes (code, touchdown x, y, z, x, y, z, xdot,
    ydot, zdot, time, work) into ``out``: on success the next apex, on failure the state at the failure."""
    g = p[I_GRAVITY]
    out[OUT_TD_X] = out[OUT_TD_Y] = out[OUT_TD_Z] = math.nan
    out[OUT_WORK] = 0.0
    write_state(out, (apex[0], apex[1], apex[2], apex[3], apex[4], 0.0), 0.0)
    foot, s, t = descend(apex, pitch, roll, p, ground, out)
    if out[OUT_CODE] != OK:
        return
    out[OUT_TD_X], out[OUT_TD_Y], out[OUT_TD_Z] = foot
    # Touchdown: the foot is pinned; the leg must be able to load and start inside the friction cone.
    if friction_margin(s[0], s[1], s[2], foot[0], foot[1], foot[2], p) < 0.0:
        out[OUT_CODE] = SLIP
        return
    if leg_rate(s, foot[0], foot[1], foot[2]) >= 0.0:
        out[OUT_CODE] = STALL
        return
    heading = heading_of(apex[3], apex[4])
    code, s, t_stance, work = stance(s, foot, heading, p, ground, stance_steps)
    t += t_stance
    out[OUT_WORK] = work
    write_state(out, s, t)
    if code != OK:
        out[OUT_CODE] = code
        return
    # Liftoff: ballistic ascent to the next apex, leg retracted.
    if s[5] <= 0.0 or progress(s[3], s[4], heading[0], heading[1]) <= 0.0:
        out[OUT_CODE] = STALL
        return
    t_up = s[5] / g
    t_hit, _, _, _ = first_contact(s[0], s[1], s[2], s[3], s[4], s[5], g, t_up, ground)
    if t_hit < t_up:
        t_up = t_hit
        out[OUT_CODE] = BODY_COLLISION
    else:
        out[OUT_CODE] = OK
    write_state(out, (s[0] + s[3] * t_up, s[1] + s[4] * t_up, s[2] + s[5] * t_up - 0.5 * g * t_up * t_up,
                      s[3], s[4], s[5] - g * t_up), t + t_up)


@compiled(parallel=False)
def step_many(apexes, angles, p, ground, stance_steps):
    """Steps from the rows of ``apexes`` (n, 5) with the leg at the rows of ``angles`` (n, 2): (n, N_OUT)."""
    n = angles.shape[0]
    out = np.empty((n, N_OUT))
    for k in range(n):
        a = apexes[k]
        step_one((a[0], a[1], a[2], a[3], a[4]), angles[k, 0], angles[k, 1], p, ground, stance_steps, out[k])
    return out

