"""The spatial SLIP's equations and guards, defined once (``drakeslip.dynamics`` in three dimensions).

Every function here is numba-compiled. The compiled step map (``drakeslip.spatial.fast_step``) calls them from
compiled code and the Drake ``SlipHopper3D`` from its derivative and witness callbacks, so both backends integrate
and guard the same model. Parameters arrive as ``SlipParams.as_array()`` (indices of ``drakeslip.dynamics``); the
ground as a ``drakeslip.spatial.heightmap.Ground3``.

The leg's touchdown direction is two angles, a gimbal's: ``pitch`` swings the foot forward (+x) and ``roll``
sideways (+y), so the foot of a straight leg sits at L0 (sin(pitch) cos(roll), sin(roll), -cos(pitch) cos(roll))
from the body. With ``roll`` 0 it is the planar leg angle. A hop's progress is measured along its heading, the
direction of the body's horizontal velocity at the apex it starts from: a hop that stops advancing along it stalls.
"""
from __future__ import annotations

import math

from drakeslip.compiled import compiled
from drakeslip.dynamics import I_FRICTION, I_GRAVITY, I_LEG_LENGTH, I_MASS, I_MIN_LEG_LENGTH, I_STIFFNESS


@compiled()
def cell_of(x, y, ground):
    """(row j, column i) of the cell under (x, y), clamped to the map's edges (where it extends flat)."""
    ny, nx = ground.heights.shape
    i = int(math.floor((x - ground.x0) / ground.cell))
    j = int(math.floor((y - ground.y0) / ground.cell))
    return min(max(j, 0), ny - 1), min(max(i, 0), nx - 1)


@compiled()
def height_at(x, y, ground):
    j, i = cell_of(x, y, ground)
    return ground.heights[j, i]


@compiled()
def leg_offset(pitch, roll, p):
    """The foot of a straight leg at rest length relative to the body, for the gimbal angles (pitch, roll)."""
    leg = p[I_LEG_LENGTH]
    return leg * math.sin(pitch) * math.cos(roll), leg * math.sin(roll), -leg * math.cos(pitch) * math.cos(roll)


@compiled()
def foot_position(x, y, z, pitch, roll, p):
    dx, dy, dz = leg_offset(pitch, roll, p)
    return x + dx, y + dy, z + dz


@compiled()
def stance_derivatives(s, fx, fy, fz, p):
    """Stance: the spring pushes the body along the leg, F = k (L0 - l) (r / l), and gravity pulls it down.
    ``s`` = (x, y, z, xdot, ydot, zdot); returns its derivative."""
    dx = s[0] - fx
    dy = s[1] - fy
    dz = s[2] - fz
    leg = math.sqrt(dx * dx + dy * dy + dz * dz)
    push = p[I_STIFFNESS] * (p[I_LEG_LENGTH] - leg) / (p[I_MASS] * leg)
    return s[3], s[4], s[5], push * dx, push * dy, push * dz - p[I_GRAVITY]


@compiled()
def stance_leg_length(x, y, z, fx, fy, fz):
    return math.sqrt((x - fx) ** 2 + (y - fy) ** 2 + (z - fz) ** 2)


@compiled()
def leg_rate(s, fx, fy, fz):
    """d/dt of the leg length (negative while the spring compresses)."""
    dx = s[0] - fx
    dy = s[1] - fy
    dz = s[2] - fz
    return (dx * s[3] + dy * s[4] + dz * s[5]) / math.sqrt(dx * dx + dy * dy + dz * dz)


@compiled()
def mechanical_energy(s, fx, fy, fz, in_stance, p):
    """Kinetic + gravitational (absolute z) + spring energy [J]."""
    energy = 0.5 * p[I_MASS] * (s[3] * s[3] + s[4] * s[4] + s[5] * s[5]) + p[I_MASS] * p[I_GRAVITY] * s[2]
    if in_stance:
        compression = p[I_LEG_LENGTH] - stance_leg_length(s[0], s[1], s[2], fx, fy, fz)
        energy += 0.5 * p[I_STIFFNESS] * compression * compression
    return energy


# ---- guards: each crosses zero (from positive) at its physical event --------------------------------------

@compiled()
def body_clearance(x, y, z, ground):
    """Body height above the cell under it; jumps negative when the body crosses into a higher cell's face."""
    return z - height_at(x, y, ground)


@compiled()
def foot_clearance(x, y, z, pitch, roll, p, ground):
    """Height of the extended foot above the cell under it (touchdown, face strike and trip guard)."""
    fx, fy, fz = foot_position(x, y, z, pitch, roll, p)
    return fz - height_at(fx, fy, ground)


@compiled()
def leg_extension(x, y, z, fx, fy, fz, p):
    """l - L0: reaches 0 from below at liftoff."""
    return stance_leg_length(x, y, z, fx, fy, fz) - p[I_LEG_LENGTH]


@compiled()
def stroke_left(x, y, z, fx, fy, fz, p):
    """l - l_min: reaches 0 when the spring bottoms out."""
    return stance_leg_length(x, y, z, fx, fy, fz) - p[I_MIN_LEG_LENGTH]


@compiled()
def friction_margin(x, y, z, fx, fy, fz, p):
    """mu (z - zf) - |horizontal leg|: negative when the axial leg force leaves the friction cone."""
    return p[I_FRICTION] * (z - fz) - math.sqrt((x - fx) ** 2 + (y - fy) ** 2)


@compiled()
def progress(xdot, ydot, heading_x, heading_y):
    """The body's speed along the hop's heading: reaches 0 when the hop stops advancing (a STALL)."""
    return xdot * heading_x + ydot * heading_y


@compiled()
def heading_of(xdot, ydot):
    """The unit direction of a horizontal velocity, (0, 0) for none."""
    speed = math.sqrt(xdot * xdot + ydot * ydot)
    if speed <= 0.0:
        return 0.0, 0.0
    return xdot / speed, ydot / speed

