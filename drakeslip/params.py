"""Physical parameters of the SLIP hopper."""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field, replace

import numpy as np

from drakeslip.apex_correction import ApexCorrection
from drakeslip.bounds import FRICTION, GRAVITY, LEG_LENGTH, MASS, STIFFNESS, Bound

# Default spring stroke: the leg bottoms out after compressing by 40 % of its rest length, the stroke of a
# typical telescoping hopper leg. For the paper's 7 kg / 0.5 m / 3200 N/m hopper that is 64 J of spring
# energy, so bottoming out is reached only by large drops (e.g. a high apex over a step down).
MIN_LEG_FRACTION = 0.6


def check_number(value, name: str, positive: bool = False, bound: Bound | None = None) -> float:
    """``value`` as a float if it is a real number (Python or numpy, not a boolean), finite, positive if asked and
    inside ``bound`` if given (``drakeslip.bounds``); else ValueError naming ``name``, the bound and the value."""
    number = math.nan
    if not isinstance(value, (bool, np.bool_)) and isinstance(value, numbers.Real):
        try:
            number = float(value)
        except OverflowError:   # an integer too large for a float
            number = math.inf
    if not math.isfinite(number) or (positive and number <= 0) \
            or (bound is not None and not bound.low <= number <= bound.high):
        kind = "a positive finite number" if positive or (bound is not None and bound.low > 0) else "a finite number"
        raise ValueError(f"{name} must be {kind}{f' in {bound}' if bound is not None else ''}, got {shown(value)}")
    return number


def shown(value) -> str:
    """``repr(value)``, cut short when long (a 400-digit integer), for an error message of one line."""
    value = value.item() if isinstance(value, np.generic) else value
    text = repr(value)
    return text if len(text) <= 40 else f"{text[:16]}... ({len(value if isinstance(value, str) else text)} characters)"


def check_count(value, name: str, low: int = 1, high: int | None = None) -> int:
    """``value`` as an int if it is an integer (Python or numpy, not a boolean) of at least ``low`` and, where given,
    at most ``high``; else ValueError."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral) or value < low:
        raise ValueError(f"{name} must be an integer of at least {low}, got {shown(value)}")
    if high is not None and value > high:
        raise ValueError(f"{name} must be an integer from {low} to {high}, got {shown(value)}")
    return int(value)


NAME_LENGTH = 100   # a name (a hopper's, a suite's, a case's id) is echoed in messages and tables, and names files


def check_name(value, name: str) -> str:
    """``value`` if it is a name: a string of 1 to NAME_LENGTH printable characters, not all spaces, with no / or
    \\ (names become file names: OUT/results-SUITE.json, OUT/HOPPER-FAMILY.json); else ValueError naming ``name``,
    the value shortened and its control characters escaped."""
    if not isinstance(value, str) or not value.strip() or len(value) > NAME_LENGTH or not value.isprintable() \
            or "/" in value or "\\" in value:
        raise ValueError(f"{name} must be a string of 1 to {NAME_LENGTH} printable characters, no / or \\, got "
                         f"{shown(value)}")
    return value


@dataclass(frozen=True)
class SlipParams:
    """A planar spring-loaded inverted pendulum: point-mass body on a massless spring leg.

    mass [kg], leg_length (spring rest length L0) [m], stiffness [N/m], gravity [m/s^2],
    friction (Coulomb coefficient at the foot), min_leg_length [m] (the spring bottoms out below this;
    default ``0.6 * leg_length``). The paper's hopper is the default; any other values inside the bounds of
    ``drakeslip.bounds`` work, e.g. Geyer's human-runner SLIP ``SlipParams(mass=80, leg_length=1,
    stiffness=10.7*80*9.81)``; ``min_leg_length`` lies in (0, leg_length).
    """

    mass: float = 7.0
    leg_length: float = 0.5
    stiffness: float = 3200.0
    gravity: float = 9.81
    friction: float = 0.8
    min_leg_length: float | None = field(default=None)

    def __post_init__(self):
        for name, bound in (("mass", MASS), ("leg_length", LEG_LENGTH), ("stiffness", STIFFNESS),
                            ("gravity", GRAVITY), ("friction", FRICTION)):
            object.__setattr__(self, name, check_number(getattr(self, name), f"SlipParams.{name}", bound=bound))
        if self.min_leg_length is None:
            object.__setattr__(self, "min_leg_length", MIN_LEG_FRACTION * self.leg_length)
        lmin = check_number(self.min_leg_length, "SlipParams.min_leg_length", positive=True)
        if not lmin < self.leg_length:
            raise ValueError(f"SlipParams.min_leg_length must lie in (0, leg_length={self.leg_length}), "
                             f"got {shown(self.min_leg_length)}")
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
        return replace(self, friction=friction)

    def as_array(self):
        """(mass, leg_length, stiffness, gravity, friction, min_leg_length) for the compiled kernels."""
        return np.array([self.mass, self.leg_length, self.stiffness, self.gravity, self.friction,
                         self.min_leg_length], dtype=np.float64)


@dataclass(frozen=True)
class RobotTemplate(SlipParams):
    """A SLIP template that stands for a robot: the SLIP's parameters fitted to the robot's hops, and ``correction``,
    the learned correction of its apex-to-apex map toward the robot's (``drakeslip.apex_correction``; a record's
    {"sha256", "path"} is read back as one, its file checked). The planners' compiled searches and robust checks
    step it as the SLIP and add the correction to each next apex; everything else (the Drake SLIP, the Python step
    map, the template's rollouts) steps the SLIP alone."""

    correction: ApexCorrection | None = None

    def __post_init__(self):
        super().__post_init__()
        if isinstance(self.correction, dict):
            object.__setattr__(self, "correction", ApexCorrection(**self.correction))
        if not isinstance(self.correction, ApexCorrection):
            raise ValueError(f"RobotTemplate.correction must be an ApexCorrection, got {self.correction!r}")

    @property
    def slip(self) -> SlipParams:
        """The SLIP alone, without the correction."""
        return SlipParams(self.mass, self.leg_length, self.stiffness, self.gravity, self.friction, self.min_leg_length)

    def as_array(self):
        """``SlipParams.as_array`` followed by the correction's network (``ApexCorrection.packed``)."""
        return np.concatenate([super().as_array(), self.correction.packed()])


def params_from_record(record: dict) -> SlipParams:
    """The hopper of a record's "params" (``dataclasses.asdict`` of one): a ``RobotTemplate`` where it names a
    correction, else ``SlipParams``."""
    if record.get("correction") is not None:
        return RobotTemplate(**record)
    return SlipParams(**{k: v for k, v in record.items() if k != "correction"})
