"""The spatial robot's geometry as its controller reads and aims it: attitude from the base's quaternion, the hip
angles that point the leg along a direction, and the leg direction that lands the foot on a point from a ballistic
flight (``aim_direction``: the robot's counterpart of the SLIP's ``drakeslip.spatial.controller.aim``, for a body
that may be rising or falling, recomputed each control period)."""
from __future__ import annotations

import math

import numpy as np

AIM_ITERATIONS = 30   # the fall time's fixed point converges by a factor of |v| |o| / (g T L) (< 0.3) a step
MAX_REACH = 0.8   # the foot's horizontal offset from the hip is kept within this share of the leg's reach


def rotation(w: float, x: float, y: float, z: float) -> np.ndarray:
    """The rotation matrix of the unit quaternion (w, x, y, z)."""
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def roll_pitch_yaw(r: np.ndarray) -> tuple:
    """Drake's roll-pitch-yaw angles of ``r`` = Rz(yaw) Ry(pitch) Rx(roll)."""
    return (math.atan2(r[2, 1], r[2, 2]), math.asin(max(-1.0, min(1.0, -r[2, 0]))), math.atan2(r[1, 0], r[0, 0]))


def hip_angles(direction_body) -> tuple:
    """(pitch, roll) hip angles that point the leg along the unit vector ``direction_body`` (body frame)."""
    dx, dy, dz = direction_body
    return math.atan2(dx, -dz), math.asin(max(-1.0, min(1.0, dy)))


def offset_direction(ox: float, oy: float, reach: float, most: float = MAX_REACH) -> np.ndarray:
    """The unit leg direction whose foot, ``reach`` from the hip, lies (ox, oy) from it horizontally (kept within
    ``most`` of the reach)."""
    r = math.hypot(ox, oy)
    if r > most * reach:
        ox, oy = ox * most * reach / r, oy * most * reach / r
    return np.array([ox, oy, -math.sqrt(reach * reach - ox * ox - oy * oy)]) / reach


def cross(a, b) -> np.ndarray:
    """a x b of two 3-vectors (numpy's cross is made for arrays of them and costs ten times more)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def fall_time(z: float, vz: float, drop: float, gravity: float) -> float:
    """Seconds until a body at height ``z`` rising at ``vz`` falls to ``z - drop`` on its ballistic path."""
    disc = vz * vz + 2.0 * gravity * drop
    return (vz + math.sqrt(disc)) / gravity if disc > 0 else max(vz / gravity, 0.0)


def aim_direction(position, velocity, target, reach: float, gravity: float) -> tuple:
    """(unit leg direction (world), fall time [s]): the direction that, held from the body at ``position`` moving at
    ``velocity`` on its ballistic path, brings the foot centre ``reach`` from the hip to ``target`` (x, y, z of the
    centre) as it falls to it, and the time that takes: a fixed point in the fall time, which depends little on
    the offset."""
    x, y, z = position
    vx, vy, vz = velocity
    tx, ty, tz = target
    ox, oy = tx - x, ty - y
    d = offset_direction(ox, oy, reach)
    t = fall_time(z, vz, z + reach * d[2] - tz, gravity)
    for _ in range(AIM_ITERATIONS):
        ox, oy = tx - x - vx * t, ty - y - vy * t
        d = offset_direction(ox, oy, reach)
        t, before = fall_time(z, vz, z + reach * d[2] - tz, gravity), t
        if abs(t - before) < 1e-12:
            break
    return d, t
