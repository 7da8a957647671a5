"""A hopper's units relative to the paper's: what turns a quantity tuned for the paper's hopper into the same
quantity for another SLIP.

The paper's hopper (``SlipParams()``: 7 kg, L0 0.5 m, 3200 N/m, g 9.81 m/s^2) is the reference. Two hoppers whose
dimensionless stiffness ``k L0 / (m g)`` and friction agree move alike (Froude similarity): lengths scale with the
leg, speeds with ``sqrt(g L0)``, times with ``sqrt(L0 / g)``. Everything hopper-dependent is written as "the paper's
value x a factor", so for the paper's hopper every factor is exactly 1.0 and every product is the paper's value to
the bit.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

from drakeslip.params import SlipParams
from drakeslip.terrain import WINDOW_AHEAD, WINDOW_BEHIND

PAPER = SlipParams()
# The Drake simulators' time limits [s], the paper's hopper's, used in every hopper's time units (``HopperUnits``):
# a hop that lasts longer than HOP_SECONDS ends the run as a TIMEOUT (``drakeslip.simulation``; the multibody
# robot's monitor calls a phase that long a STALL), and a run of unlisted hops stops after RUN_SECONDS. A hop of
# the paper's hopper takes under a second on the suites' terrains; 5 s is 22 time units sqrt(L0 / g), more than
# the two flights of a hop from any start inside ``drakeslip.bounds`` (13.4) and its stance.
HOP_SECONDS = 5.0
RUN_SECONDS = 60.0


@dataclass(frozen=True)
class HopperUnits:
    """Scale factors of a hopper relative to the paper's, and its dimensionless stiffness.

    length: L0 / 0.5 m (terrain lengths and heights, positions, leg lengths); speed: sqrt(g L0 / (9.81 * 0.5))
    (forward speeds, Froude similarity); time: length / speed; mass: m / 7 kg; stiffness: k L0 / (m g),
    dimensionless (23.3 for the paper's hopper; it and the friction are what similarity cannot scale away).
    """

    length: float
    speed: float
    time: float
    mass: float
    stiffness: float

    @classmethod
    def of(cls, params: SlipParams) -> "HopperUnits":
        if not isinstance(params, SlipParams):
            raise TypeError(f"HopperUnits.of takes SlipParams, got {type(params).__name__}")
        length = params.leg_length / PAPER.leg_length
        # g L0 over the paper's g L0: both products are one rounding of the same factors for the paper's hopper,
        # so the ratio, and its square root, is exactly 1.0 there.
        speed = math.sqrt((params.gravity * params.leg_length) / (PAPER.gravity * PAPER.leg_length))
        return cls(length=length, speed=speed, time=length / speed, mass=params.mass / PAPER.mass,
                   stiffness=dimensionless_stiffness(params))

    @property
    def window(self) -> tuple[float, float]:
        """The perception window [m] ahead of and behind the body: the paper's (8 m, 3 m) in this hopper's lengths
        (``Terrain.perceived(x, *units.window)``)."""
        return WINDOW_AHEAD * self.length, WINDOW_BEHIND * self.length

    @property
    def hop_seconds(self) -> float:
        """HOP_SECONDS in this hopper's time units [s]: how long one hop may last on a Drake simulator."""
        return HOP_SECONDS * self.time

    def length_or(self, value: float | None, paper: float) -> float:
        """A length option: ``value`` [m] when given, else the paper's ``paper`` [m] in this hopper's lengths."""
        return paper * self.length if value is None else value

    def speed_or(self, value: float | None, paper: float) -> float:
        """A speed option: ``value`` [m/s] when given, else the paper's ``paper`` [m/s] in this hopper's speeds."""
        return paper * self.speed if value is None else value

    def time_or(self, value: float | None, paper: float) -> float:
        """A time option: ``value`` [s] when given, else the paper's ``paper`` [s] in this hopper's times."""
        return paper * self.time if value is None else value


@functools.lru_cache(maxsize=256)
def units_of(params: SlipParams) -> HopperUnits:
    """``HopperUnits.of(params)``, computed once per hopper (planners ask for it at every node)."""
    return HopperUnits.of(params)


def dimensionless_stiffness(params: SlipParams) -> float:
    """k L0 / (m g): the spring's force at a full leg's compression in body weights."""
    return params.stiffness * params.leg_length / (params.mass * params.gravity)
