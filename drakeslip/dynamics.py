"""The SLIP equations and guards, defined once.

Every function here is a numba-compiled scalar function. The fast backend (``fast_step``) calls them from
compiled code; the Drake ``SlipHopper`` calls the same functions from its derivative and witness callbacks,
so both backends integrate and guard exactly the same model.

Parameters arrive as the array ``p = SlipParams.as_array()``: (mass, leg_length, stiffness, gravity,
friction, min_leg_length). Terrain arrives as ``(heights, x0, cell)``.
"""
from __future__ import annotations

import math

from drakeslip.compiled import compiled


# The index of each field in p (I_ for index: p[I_LEG_LENGTH] is the rest length L0).
I_MASS, I_LEG_LENGTH, I_STIFFNESS, I_GRAVITY, I_FRICTION, I_MIN_LEG_LENGTH = range(6)

# A foot or body that reaches terrain by crossing a cell edge more than this far below the new cell's top
# hit the vertical face; within it, it landed on the corner. Both backends classify contacts with it.
FACE_TOLERANCE = 1e-5


@compiled()
def cell_index(x, x0, cell, n):
    i = int(math.floor((x - x0) / cell))
    return min(max(i, 0), n - 1)


@compiled()
def height_at(heights, x0, cell, x):
    return heights[cell_index(x, x0, cell, heights.shape[0])]


@compiled()
def stance_derivatives(x, z, xdot, zdot, foot_x, foot_z, p):
    """Stance: the body is pushed along the leg by the spring, F = k (L0 - l) (r / l), and pulled by gravity.
    Returns (xdot, zdot, xddot, zddot)."""
    dx = x - foot_x
    dz = z - foot_z
    leg = math.sqrt(dx * dx + dz * dz)
    push = p[I_STIFFNESS] * (p[I_LEG_LENGTH] - leg) / (p[I_MASS] * leg)
    return xdot, zdot, push * dx, push * dz - p[I_GRAVITY]


@compiled()
def foot_position(x, z, leg_angle, p):
    """Foot of a straight leg at rest length: theta from vertical, positive = foot ahead."""
    return x + p[I_LEG_LENGTH] * math.sin(leg_angle), z - p[I_LEG_LENGTH] * math.cos(leg_angle)


@compiled()
def stance_leg_length(x, z, foot_x, foot_z):
    return math.sqrt((x - foot_x) ** 2 + (z - foot_z) ** 2)


@compiled()
def leg_rate(x, z, xdot, zdot, foot_x, foot_z):
    """d/dt of the leg length (negative while the spring compresses)."""
    dx = x - foot_x
    dz = z - foot_z
    return (dx * xdot + dz * zdot) / math.sqrt(dx * dx + dz * dz)


@compiled()
def mechanical_energy(x, z, xdot, zdot, foot_x, foot_z, in_stance, p):
    """Kinetic + gravitational (absolute z) + spring energy [J]."""
    energy = 0.5 * p[I_MASS] * (xdot * xdot + zdot * zdot) + p[I_MASS] * p[I_GRAVITY] * z
    if in_stance:
        compression = p[I_LEG_LENGTH] - stance_leg_length(x, z, foot_x, foot_z)
        energy += 0.5 * p[I_STIFFNESS] * compression * compression
    return energy


# ---- guards: each crosses zero (from positive) at its physical event --------------------------------------

@compiled()
def body_clearance(x, z, heights, x0, cell):
    """Body height above the terrain under it; jumps negative when the body crosses into a higher cell's face."""
    return z - height_at(heights, x0, cell, x)


@compiled()
def foot_clearance(x, z, leg_angle, p, heights, x0, cell):
    """Height of the extended foot above the terrain under it (touchdown, foot-wall strike and trip guard)."""
    fx, fz = foot_position(x, z, leg_angle, p)
    return fz - height_at(heights, x0, cell, fx)


@compiled()
def leg_extension(x, z, foot_x, foot_z, p):
    """l - L0: reaches 0 from below at liftoff."""
    return stance_leg_length(x, z, foot_x, foot_z) - p[I_LEG_LENGTH]


@compiled()
def stroke_left(x, z, foot_x, foot_z, p):
    """l - l_min: reaches 0 when the spring bottoms out."""
    return stance_leg_length(x, z, foot_x, foot_z) - p[I_MIN_LEG_LENGTH]


@compiled()
def friction_margin(x, z, foot_x, foot_z, p):
    """mu (z - zf) - |x - xf|: negative when the (axial) leg force leaves the friction cone."""
    return p[I_FRICTION] * (z - foot_z) - abs(x - foot_x)


@compiled()
def classify_foot_contact(foot_z, terrain_height, ditch_height):
    """What the foot met: 0 = a touchdown on a top surface, else FailureMode.FOOT_COLLISION (2) for a strike
    on a vertical face (foot more than FACE_TOLERANCE below the top it entered) or a landing in a ditch."""
    if foot_z < terrain_height - FACE_TOLERANCE or terrain_height <= ditch_height:
        return 2
    return 0
