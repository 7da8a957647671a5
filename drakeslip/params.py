"""Physical parameters of the SLIP hopper."""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field

import numpy as np

# Default spring stroke: the leg bottoms out after compressing by 40 % of its rest length, the stroke of a
# typical telescoping hopper leg. For the paper's 7 kg / 0.5 m / 3200 N/m hopper that is 64 J of spring
# energy, so bottoming out is reached only by large drops (e.g. a high apex over a step down).
MIN_LEG_FRACTION = 0.6


def check_number(value, name: str, positive: bool = False) -> float:
    """``value`` as a float if it is a real number (Python or numpy, not a boolean), finite, and positive if asked;
    else ValueError naming ``name`` and the value."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real) or not math.isfinite(value) \
            or (positive and value <= 0):
        kind = "a positive finite number" if positive else "a finite number"
        raise ValueError(f"{name} must be {kind}, got {value!r}")
    return float(value)


def check_count(value, name: str, low: int = 1) -> int:
    """``value`` as an int if it is an integer (Python or numpy, not a boolean) of at least ``low``; else ValueError."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral) or value < low:
        raise ValueError(f"{name} must be an integer of at least {low}, got {value!r}")
    return int(value)


@dataclass(frozen=True)
class SlipParams:
    """A planar spring-loaded inverted pendulum: point-mass body on a massless spring leg.

    mass [kg], leg_length (spring rest length L0) [m], stiffness [N/m], gravity [m/s^2],
    friction (Coulomb coefficient at the foot), min_leg_length [m] (the spring bottoms out below this;
    default ``0.6 * leg_length``). The paper's hopper is the default; any other positive values work,
    e.g. Geyer's human-runner SLIP ``SlipParams(mass=80, leg_length=1, stiffness=10.7*80*9.81)``.
    """

    mass: float = 7.0
    leg_length: float = 0.5
    stiffness: float = 3200.0
    gravity: float = 9.81
    friction: float = 0.8
    min_leg_length: float | None = field(default=None)

    def __post_init__(self):
        for name in ("mass", "leg_length", "stiffness", "gravity", "friction"):
            object.__setattr__(self, name, check_number(getattr(self, name), f"SlipParams.{name}", positive=True))
        if self.min_leg_length is None:
            object.__setattr__(self, "min_leg_length", MIN_LEG_FRACTION * self.leg_length)
        lmin = check_number(self.min_leg_length, "SlipParams.min_leg_length", positive=True)
        if not lmin < self.leg_length:
            raise ValueError(
                f"SlipParams.min_leg_length must lie in (0, leg_length={self.leg_length}), got {self.min_leg_length!r}")
        object.__setattr__(self, "min_leg_length", lmin)

    @property
    def natural_frequency(self) -> float:
        """sqrt(k/m) [rad/s]: sets the stance time scale (half a period is about pi / omega)."""
        return math.sqrt(self.stiffness / self.mass)

    @property
    def max_leg_angle(self) -> float:
        """Largest |leg angle| [rad] whose touchdown force lies inside the friction cone: atan(friction)."""
        return math.atan(self.friction)

    def with_friction(self, friction: float) -> "SlipParams":
        return SlipParams(self.mass, self.leg_length, self.stiffness, self.gravity, friction, self.min_leg_length)

    def as_array(self):
        """(mass, leg_length, stiffness, gravity, friction, min_leg_length) for the compiled kernels."""
        return np.array([self.mass, self.leg_length, self.stiffness, self.gravity, self.friction,
                         self.min_leg_length], dtype=np.float64)
