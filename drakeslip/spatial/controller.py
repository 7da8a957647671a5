"""The spatial hopper's low-level controller: from an apex and a wanted foothold to the leg's touchdown angles.

In flight the body and the leg-held foot fall together on a parabola, so the foot that leaves the apex at the
offset o = (ox, oy, oz) (|o| = L0) lands on a surface at height zf after T = sqrt(2 (z + oz - zf) / g), at
(x + ox + xdot T, y + oy + ydot T). ``aim`` solves that for the horizontal offset that lands on the wanted (xf, yf)
with Newton's method (the Jacobian is the identity plus the velocity times dT/do, which is small), starting from
the offset that ignores the drift's dependence on the angles; it is exact for a flight that meets nothing before
the wanted foothold, for any hopper (it reads only L0 and g). The step map says whether the flight does: a foot
that meets a face or another surface first lands elsewhere, and a planner drops that child.
"""
from __future__ import annotations

import math

import numpy as np

from drakeslip.compiled import compiled
from drakeslip.dynamics import I_GRAVITY, I_LEG_LENGTH

NEWTON_STEPS = 8
# The offset is kept this far inside a horizontal leg, where a foot at rest length can no longer fall
MAX_TILT_COS = 0.05


@compiled()
def aim(apex, target, p):
    """(pitch, roll, miss) for the spatial hop from ``apex`` (x, y, z, xdot, ydot) to the foothold ``target`` (x, y,
    z): the gimbal angles (``drakeslip.spatial.dynamics``) and the predicted landing's horizontal distance from the
    target [m] (0 up to rounding where it is reachable; NaN where the target's surface is not below the foot)."""
    leg, g = p[I_LEG_LENGTH], p[I_GRAVITY]
    x, y, z, vx, vy = apex
    tx, ty, tz = target
    drop = z - tz
    if not drop > leg * MAX_TILT_COS:
        return 0.0, 0.0, math.nan
    # first guess: the fall time of a vertical leg, the offset that closes the gap left by the drift
    t = math.sqrt(2.0 * max(drop - leg, 1e-9 * leg) / g)
    ox, oy = clamp_offset(tx - x - vx * t, ty - y - vy * t, leg)
    miss = math.nan
    for _ in range(NEWTON_STEPS):
        oz = -math.sqrt(max(leg * leg - ox * ox - oy * oy, (leg * MAX_TILT_COS) ** 2))
        fall = drop + oz
        if not fall > 0.0:
            return 0.0, 0.0, math.nan
        t = math.sqrt(2.0 * fall / g)
        rx = ox + vx * t - (tx - x)
        ry = oy + vy * t - (ty - y)
        miss = math.sqrt(rx * rx + ry * ry)
        # dT/do = (1 / (g T)) d oz / do, with d oz / d ox = -ox / oz
        dtx, dty = -ox / (oz * g * t), -oy / (oz * g * t)
        a, b, c, d = 1.0 + vx * dtx, vx * dty, vy * dtx, 1.0 + vy * dty
        det = a * d - b * c
        if det == 0.0:
            break
        ox, oy = clamp_offset(ox - (d * rx - b * ry) / det, oy - (a * ry - c * rx) / det, leg)
    oz = -math.sqrt(max(leg * leg - ox * ox - oy * oy, (leg * MAX_TILT_COS) ** 2))
    fall = drop + oz
    if not fall > 0.0:
        return 0.0, 0.0, math.nan
    t = math.sqrt(2.0 * fall / g)
    miss = math.sqrt((ox + vx * t - (tx - x)) ** 2 + (oy + vy * t - (ty - y)) ** 2)
    return math.atan2(ox, -oz), math.asin(oy / leg), miss


@compiled()
def clamp_offset(ox, oy, leg):
    """(ox, oy) shortened to keep the leg at least MAX_TILT_COS L0 below the hip."""
    most = leg * math.sqrt(1.0 - MAX_TILT_COS * MAX_TILT_COS)
    r = math.sqrt(ox * ox + oy * oy)
    if r > most:
        return ox * most / r, oy * most / r
    return ox, oy


@compiled()
def aim_many(apexes, targets, p):
    """``aim`` for each row of ``apexes`` (n, 5) and ``targets`` (n, 3): (n, 3) rows of (pitch, roll, miss)."""
    n = apexes.shape[0]
    out = np.empty((n, 3))
    for k in range(n):
        a, f = apexes[k], targets[k]
        out[k, 0], out[k, 1], out[k, 2] = aim((a[0], a[1], a[2], a[3], a[4]), (f[0], f[1], f[2]), p)
    return out


def leg_angles_for(apex, target, params) -> tuple:
    """(pitch, roll) that lands the hop from ``apex`` (x, y, z, xdot, ydot) on ``target`` (x, y, z) when its flight
    meets nothing before; ValueError when the target is not below the foot's reach."""
    pitch, roll, miss = aim(tuple(float(v) for v in apex), tuple(float(v) for v in target), params.as_array())
    if not math.isfinite(miss):
        raise ValueError(f"the foothold {tuple(target)} is not below the reach of a leg at the apex {tuple(apex)}")
    return pitch, roll
