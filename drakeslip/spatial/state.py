"""State conventions of the spatial hopper (``drakeslip.state`` in three dimensions): x forward, y to the left, z up,
world frame, metres; the body a point mass.

* ``ApexState3D(x, y, z, xdot, ydot)``: the body at the top of a flight (no vertical velocity), z absolute.
* The leg's touchdown direction: the gimbal angles (pitch, roll) of ``drakeslip.spatial.dynamics``.
* A foothold: (x, y, z) of the foot's contact point.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

from drakeslip.bounds import POSITION, SPEED
from drakeslip.params import SlipParams, check_number
from drakeslip.spatial.heightmap import HeightMap
from drakeslip.state import FailureMode

APEX3D_FIELDS = ("x", "y", "z", "xdot", "ydot")


class ApexState3D(NamedTuple):
    """The body at the top of a flight: position (x, y, z) [m, z absolute] and horizontal velocity [m/s]."""

    x: float
    y: float
    z: float
    xdot: float
    ydot: float


@dataclass(frozen=True)
class StepResult3D:
    """One spatial hop (``drakeslip.state.StepResult`` in three dimensions): ``foothold`` (x, y, z) of the touchdown
    (NaN without one); ``next_apex`` an ApexState3D, None on failure; ``end_state`` (x, y, z, xdot, ydot, zdot) at the
    next apex or the failure."""

    ok: bool
    failure: FailureMode | None
    foothold: tuple
    next_apex: tuple | None
    time: float
    end_state: tuple
    work: int


def check_apex3d(apex, height_map: HeightMap, params: SlipParams) -> tuple:
    """``apex`` as five floats (x, y, z, xdot, ydot) after checking the inputs of a hop: a HeightMap, SlipParams, every
    component finite and inside its bound (POSITION, SPEED of ``drakeslip.bounds``), the body above the map."""
    if not isinstance(height_map, HeightMap):
        raise TypeError(f"height_map must be a drakeslip.spatial.HeightMap, got {type(height_map).__name__}")
    if not isinstance(params, SlipParams):
        raise TypeError(f"params must be a drakeslip.SlipParams, got {type(params).__name__}")
    try:
        values = tuple(apex)
    except TypeError:
        values = ()
    if len(values) != 5:
        raise ValueError(f"apex must be (x, y, z, xdot, ydot), got {apex!r}")
    apex = tuple(check_number(v, f"apex.{name}", bound=POSITION if name in "xyz" else SPEED)
                 for name, v in zip(APEX3D_FIELDS, values))
    ground = height_map.solid[height_map.index(apex[0], apex[1])]
    if apex[2] <= ground:
        raise ValueError(f"apex z={apex[2]} is not above the map (height {ground} at x={apex[0]}, y={apex[1]})")
    return apex
