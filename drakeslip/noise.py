"""Noise profiles: how far the robot's knowledge and commands are from the world they act in.

A profile has four kinds of noise, each drawn from a seeded generator so that a run is repeatable:

* state estimation: the apex the planner and the controller are told is the true one plus Gaussian errors
  (``apex`` = standard deviations of x [m], z [m], xdot [m/s]), drawn at every apex;
* actuation: the leg angle reached is the commanded one plus a Gaussian error (``leg_angle`` [rad]), every hop;
* model mismatch: the executed hopper's stiffness and mass are the model's times (1 + u) and its friction the
  model's plus u, u uniform in +-``stiffness``, +-``mass`` (relative) and +-``friction`` (absolute), drawn once
  per case (the planner and the controller keep the model's values);
* terrain perception: every solid cell of the terrain the planner and the controller see is off by a Gaussian
  error (``heights`` [m]), and all its edges are displaced together by a Gaussian error (``edges`` [m]: the map
  registered against the robot), drawn at every planning call.

``realistic`` is a robot with a decent state estimator and position-controlled leg: 5 mm and 2 cm/s of apex
error, 0.005 rad of leg angle, 2 % of stiffness and mass, 0.05 of friction, 1 cm of terrain height and edge
position. ``scaled(k)`` multiplies every size by k.

A profile's sizes are those of the paper's hopper (``drakeslip.units``); another hopper's sensors and actuators
are as good for its size (``for_hopper``): its position, terrain height and edge errors are the profile's times its
length factor, its apex speed error times its speed factor and its friction error times its friction over the
paper's 0.8, while the leg angle [rad] and the relative stiffness and mass errors, dimensionless, stay. A robot's
state estimate comes from its leg's kinematics and its map from a sensor looking as far ahead as its perception
window, both in its lengths; with the errors in metres whatever the hopper, a 0.3 m leg would carry 1.7 times the
paper's relative errors and a 1.2 m leg 0.4 times them, and a Froude-similar hopper would not run as the paper's
does. For the paper's hopper every factor is exactly 1.0 and ``for_hopper`` returns the profile itself.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np

from drakeslip.params import SlipParams, check_number
from drakeslip.terrain import Terrain
from drakeslip.units import PAPER, units_of

MIN_FRICTION = 0.05  # a drawn friction coefficient never goes below this


@dataclass(frozen=True)
class NoiseProfile:
    """Sizes of each kind of noise (see the module doc); all zero is the noiseless protocol."""

    apex: tuple = (0.0, 0.0, 0.0)   # std of the apex told: x [m], z [m], xdot [m/s]
    leg_angle: float = 0.0          # std of the leg angle reached [rad]
    stiffness: float = 0.0          # half-range of the relative stiffness error of the executed hopper
    mass: float = 0.0               # half-range of its relative mass error
    friction: float = 0.0           # half-range of its friction error (absolute)
    heights: float = 0.0            # std of each perceived cell height [m]
    edges: float = 0.0              # std of the perceived terrain's shift along x [m]

    def __post_init__(self):
        apex = tuple(self.apex)
        if len(apex) != 3:
            raise ValueError(f"NoiseProfile.apex must be (x, z, xdot) standard deviations, got {self.apex!r}")
        object.__setattr__(self, "apex", tuple(check_number(v, "NoiseProfile.apex") for v in apex))
        for name in ("leg_angle", "stiffness", "mass", "friction", "heights", "edges"):
            object.__setattr__(self, name, check_number(getattr(self, name), f"NoiseProfile.{name}"))
        sizes = {**{f"apex[{i}]": v for i, v in enumerate(self.apex)},
                 **{name: getattr(self, name) for name in ("leg_angle", "stiffness", "mass", "friction", "heights",
                                                           "edges")}}
        negative = [f"{name} {value:g}" for name, value in sizes.items() if value < 0]
        if negative:
            raise ValueError(f"noise sizes must not be negative, got {', '.join(negative)}")
        if max(self.stiffness, self.mass) >= 1:
            raise ValueError(f"relative stiffness and mass errors must be below 1, got stiffness {self.stiffness:g} "
                             f"and mass {self.mass:g}")

    @property
    def silent(self) -> bool:
        """No noise at all (the noiseless protocol)."""
        return not any((*self.apex, self.leg_angle, self.stiffness, self.mass, self.friction, self.heights,
                        self.edges))

    def scaled(self, k: float) -> "NoiseProfile":
        """Every size times ``k``."""
        k = check_number(k, "noise scale")
        return NoiseProfile(tuple(k * v for v in self.apex), k * self.leg_angle, k * self.stiffness, k * self.mass,
                            k * self.friction, k * self.heights, k * self.edges)

    def to_dict(self) -> dict:
        return {**asdict(self), "apex": list(self.apex)}

    def for_hopper(self, params: SlipParams) -> "NoiseProfile":
        """This profile, its sizes the paper's hopper's, for the hopper ``params`` (see the module doc): lengths
        times its length factor, the apex speed error times its speed factor, the friction error times
        ``friction_factor(params)``. The profile itself for the paper's hopper."""
        units, grip = units_of(params), friction_factor(params)
        length, speed = units.length, units.speed
        if length == speed == grip == 1.0:
            return self
        x, z, xdot = self.apex
        return NoiseProfile((x * length, z * length, xdot * speed), self.leg_angle, self.stiffness, self.mass,
                            self.friction * grip, self.heights * length, self.edges * length)

    # ---- draws ------------------------------------------------------------------------------------------------
    def executed_params(self, params: SlipParams, rng: np.random.Generator) -> SlipParams:
        """The executed hopper: the model with this case's stiffness, mass and friction errors."""
        u = rng.uniform(-1.0, 1.0, 3)
        return replace(params, stiffness=params.stiffness * (1 + self.stiffness * u[0]),
                       mass=params.mass * (1 + self.mass * u[1]),
                       friction=max(params.friction + self.friction * u[2], MIN_FRICTION))

    def apex_errors(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """(n, 3) errors of the apexes told, one row per apex."""
        return rng.normal(size=(n, 3)) * np.asarray(self.apex)

    def angle_errors(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """(n,) errors of the leg angles reached."""
        return rng.normal(size=n) * self.leg_angle

    def perceived(self, terrain: Terrain, rng: np.random.Generator, map_filter: int = 1) -> Terrain:
        """The terrain as sensed: each solid cell's height off by a Gaussian error, the whole map shifted along x;
        ditch cells stay ditches. ``map_filter``: the cells of the median filter the robot runs on it
        (``Terrain.denoised`` with this profile's height error; 1: the map as sensed)."""
        heights = terrain.heights.copy()
        solid = heights > terrain.ditch_height
        heights[solid] += rng.normal(size=int(solid.sum())) * self.heights
        shift = float(rng.normal()) * self.edges
        return Terrain(heights, terrain.cell, terrain.x0 + shift, terrain.ditch_height,
                       terrain.extends_flat).denoised(self.heights, map_filter)


def friction_factor(params: SlipParams) -> float:
    """The hopper's friction coefficient over the paper's (0.8): what a friction error made for the paper's hopper is
    multiplied by for it (1.0 for the paper's)."""
    return params.friction / PAPER.friction


PROFILES = {
    "none": NoiseProfile(),
    "realistic": NoiseProfile(apex=(0.005, 0.005, 0.02), leg_angle=0.005, stiffness=0.02, mass=0.02, friction=0.05,
                              heights=0.01, edges=0.01),
}
# one kind of noise at a time, at its realistic size: which of them breaks a plan
PROFILES.update({
    "state": NoiseProfile(apex=PROFILES["realistic"].apex),
    "actuation": NoiseProfile(leg_angle=PROFILES["realistic"].leg_angle),
    "model": NoiseProfile(stiffness=0.02, mass=0.02, friction=0.05),
    "terrain": NoiseProfile(heights=0.01, edges=0.01),
})


def profile(spec: str) -> NoiseProfile:
    """A profile by name, or ``NAME*K`` for a named profile scaled by K (e.g. ``realistic*0.5``)."""
    name, _, scale = str(spec).partition("*")
    if name not in PROFILES:
        raise ValueError(f"unknown noise profile {name!r}; known: {', '.join(PROFILES)} (NAME*K scales one)")
    if not scale:
        return PROFILES[name]
    try:
        k = float(scale)
    except ValueError:
        raise ValueError(f"noise scale in {spec!r} must be a number") from None
    if not (k >= 0 and k == k and k != float("inf")):
        raise ValueError(f"noise scale in {spec!r} must be a finite number >= 0")
    try:
        return PROFILES[name].scaled(k)
    except ValueError as error:   # a scale that makes a relative error 100 % or more
        raise ValueError(f"noise {spec!r}: {error}") from None


def scale_of(noise: NoiseProfile, named: NoiseProfile) -> float | None:
    """K when ``noise`` is ``named.scaled(K)`` (0 for no noise at all), else None."""
    sizes = lambda p: np.array([*p.apex, p.leg_angle, p.stiffness, p.mass, p.friction, p.heights, p.edges])
    v, ref = sizes(noise), sizes(named)
    if not ref.any():
        return None
    k = float(v @ ref / (ref @ ref))
    return k if np.allclose(v, k * ref, rtol=1e-9, atol=1e-15) else None


def describe(noise: NoiseProfile) -> str:
    """A profile's name as ``profile`` reads it (``realistic``, ``realistic*0.5``), or "custom"."""
    for name, named in PROFILES.items():
        if noise == named:
            return name
    for name, named in PROFILES.items():
        k = scale_of(noise, named)
        if k is not None:
            return f"{name}*{k:g}"
    return "custom"
