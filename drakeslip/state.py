"""State conventions shared by every part of drakeslip.

Coordinates: x forward, z up, world frame, metres. The body is a point mass at (x, z).

* ``ApexState(x, z, xdot)`` — the body at the top of a flight phase (vertical velocity zero); ``z`` is the
  absolute body height in the world frame (not height above the terrain).
* Leg angle ``theta`` — radians from vertical; **positive puts the foot ahead (+x) of the body**. It is
  commanded at apex and held for the rest of the flight, so the foot sits at
  ``(x + L0 sin(theta), z - L0 cos(theta))`` until touchdown. Between liftoff and the next apex the leg
  is retracted (it is massless and cannot touch the ground).
* ``touchdown_x`` — the x of the foot's contact point (the foothold).
* Full state ``(x, z, xdot, zdot)``; in stance the foot is pinned at ``(foot_x, foot_z)``.
"""
from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from typing import NamedTuple

from drakeslip.bounds import APEX_HEIGHT, APEX_SPEED, POSITION, SPEED
from drakeslip.params import SlipParams, check_number
from drakeslip.terrain import Terrain


APEX_BOUNDS = (POSITION, POSITION, SPEED)   # of x, z, xdot


class ApexState(NamedTuple):
    x: float
    z: float
    xdot: float

    def validate(self, name: str = "apex") -> "ApexState":
        """This apex with every component a finite float inside its bound (``drakeslip.bounds``: POSITION for x
        and z, SPEED for xdot); ValueError naming a bad one (NaN, a boolean, text, 1e308)."""
        return ApexState(*(check_number(value, f"{name}.{field_name}", bound=bound)
                           for field_name, value, bound in zip(self._fields, self, APEX_BOUNDS)))


class FailureMode(enum.IntEnum):
    """Why a hop failed. Codes are shared with the compiled backend (0 means no failure)."""

    BODY_COLLISION = 1  # the body reaches the terrain (a top surface or a vertical face)
    FOOT_COLLISION = 2  # the swinging foot strikes a vertical face, or lands in a ditch (see Terrain)
    SLIP = 3            # during stance the leg force leaves the friction cone: |x-xf| > mu (z-zf)
    BOTTOM_OUT = 4      # the leg compresses below min_leg_length
    TRIP = 5            # at apex the commanded foot position is not above the terrain
    STALL = 6           # no forward progress: xdot reaches 0, or no apex follows liftoff
    # Not a guard of the model: the hop outlasted the Drake simulator's per-hop limit (``HopperUnits.hop_seconds``)
    # before any guard fired, so the run was cut, not failed. The fast backend, which has no such limit, never
    # gives it.
    TIMEOUT = 7

    @classmethod
    def from_code(cls, code: int) -> "FailureMode | None":
        return None if code == 0 else cls(int(code))


class SimulationCrash(RuntimeError):
    """A simulation that stopped before it could say what the hopper does: its integrator raised, or the hopper's
    derivatives were not finite (``drakeslip.simulation``), or, where a check needs every hop to end, a hop timed out
    (``FailureMode.TIMEOUT``). Not a failure of the hopper and not a verdict on its commands: the scripts report it
    in one line with exit status 3 (``drakeslip.jobs.cli.CRASHED``)."""


@dataclass(frozen=True)
class StepResult:
    """Outcome of one apex-to-apex step f(a, t, theta).

    ``ok`` — the hop reached the next apex with no failure; ``failure`` — the first failure, else None;
    ``touchdown_x`` — the foothold (NaN if the foot never touched down); ``next_apex`` — None on failure;
    ``time`` — seconds from the start apex to the next apex, or to the failure; ``end_state`` —
    (x, z, xdot, zdot) at that moment (where and how the failure happened); ``work`` — integration steps.
    """

    ok: bool
    failure: FailureMode | None
    touchdown_x: float
    next_apex: ApexState | None
    time: float
    end_state: tuple
    work: int


def as_apex(apex, name: str = "apex") -> ApexState:
    """``apex`` (any sequence of three numbers) as a checked ApexState of floats."""
    try:
        x, z, xdot = apex
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be (x, z, xdot), got {apex!r}") from None
    return ApexState(x, z, xdot).validate(name)


def check_apex(apex, terrain: Terrain, params: SlipParams) -> ApexState:
    """``apex`` as an ApexState of floats, after checking the inputs of a hop: a Terrain, SlipParams, a finite
    apex above the terrain. Raises TypeError or ValueError naming the bad value."""
    if not isinstance(terrain, Terrain):
        raise TypeError(f"terrain must be a drakeslip.Terrain, got {type(terrain).__name__}")
    if not isinstance(params, SlipParams):
        raise TypeError(f"params must be a drakeslip.SlipParams, got {type(params).__name__}")
    apex = as_apex(apex)
    ground = terrain.height_at(apex.x)
    if apex.z <= ground:
        raise ValueError(f"apex z={apex.z} is not above the terrain (height {ground} at x={apex.x})")
    return apex


def check_start(apex, terrain: Terrain, params: SlipParams, name: str = "apex") -> ApexState:
    """``check_apex``, and a start apex a user gives inside the bounds of ``drakeslip.bounds`` in the hopper's units:
    at most APEX_HEIGHT leg lengths above the ground under it and at most APEX_SPEED sqrt(g L0) fast; ValueError
    naming ``name``, the value and the bound in metres for this hopper."""
    apex = check_apex(apex, terrain, params)
    ground, leg = terrain.height_at(apex.x), params.leg_length
    if apex.z - ground > APEX_HEIGHT.high * leg:
        raise ValueError(f"{name} z={apex.z:g} m is {apex.z - ground:g} m above the ground at x={apex.x:g}: more than "
                         f"{APEX_HEIGHT.high:g} leg lengths ({APEX_HEIGHT.high * leg:g} m for this hopper; APEX_HEIGHT "
                         "of drakeslip/bounds.py)")
    fastest = APEX_SPEED.high * math.sqrt(params.gravity * leg)
    if abs(apex.xdot) > fastest:
        raise ValueError(f"{name} xdot={apex.xdot:g} m/s is faster than {APEX_SPEED.high:g} sqrt(g L0) ({fastest:.4g} "
                         "m/s for this hopper; APEX_SPEED of drakeslip/bounds.py)")
    return apex


def check_leg_angle(leg_angle: float) -> float:
    """``leg_angle`` as a float, if it is finite and inside (-pi/2, pi/2); else ValueError naming it."""
    leg_angle = float(leg_angle)
    if not math.isfinite(leg_angle) or abs(leg_angle) >= math.pi / 2:
        raise ValueError(f"leg_angle must be finite and within (-pi/2, pi/2), got {leg_angle!r}")
    return leg_angle
