"""Children that survive noise: every hop of a sequence's first ``depth`` is flown by a set of perturbed robots
(particles) at once, and kept only if all of them make it and can go on from where they land.

The planner believes the hopper is at apex ``a``. A real robot is somewhere near ``a`` (state estimation), its
leg reaches the controller's angle give or take (actuation), its spring and mass are not quite the model's and
the ground's friction is uncertain (model mismatch), and the ground is not quite where the map says
(perception). Each particle is one such robot: it starts from ``a - e`` and is told it is ``e`` off where it is at
every apex (its estimate is biased by ``e``), adds ``d`` to every leg angle the controller gives it, hops with
its own stiffness and mass over the map raised or shifted by its own terrain error, and with a friction
``friction_loss`` below the model's. The errors are the corners of the noise box (each at +-``sigmas`` standard
deviations of ``noise``, or its half-range for the model's uniform errors, one at a time), so the search stays
deterministic.

A search checks a node when it pops it (lazily: only the nodes the search gets to): every particle that reached
the node's parent aims at the node's foothold with the controller from the apex it is told (as the robot would,
executing a plan's footholds) and hops. The node is robust when every particle completes the hop, touches down
within ``landing`` of the foothold on the same level, clear of its edges by ``edge_margin``, and keeps
``min_speed`` at its next apex, that apex ``min_clearance`` leg lengths above the ground under it (lower, in a
fast skimming gait, only leg angles near the friction cone's edge reach the ground without striking it first,
which is where noisy runs slip and trip); the node's particles are those next apexes. At the last robust hop
every particle must also find at least ``lookahead`` working hops in a fan of leg angles from where it lands: a
robot that replans from there needs a way on. A check is one controller call and one compiled call that flies
the particles, each with its own hopper over its own terrain, and stops at the first that fails.

The margins (``landing``, ``edge_margin``, ``min_speed``) left at None are the paper's hopper's (LANDING,
EDGE_MARGIN, MIN_SPEED) in the hopper's units, as every planner setting is (``planners.base.Planner``); given, they
are in metres and m/s. The noise, like the closed loop's, is the paper's hopper's in the hopper's units
(``NoiseProfile.for_hopper``), and the ``friction_loss`` left at None the paper's hopper's FRICTION_LOSS in
proportion to the hopper's friction (``drakeslip.noise.friction_factor``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from drakeslip import SlipParams, Terrain
from drakeslip.dynamics import I_FRICTION, I_MASS, I_STIFFNESS
from drakeslip.noise import PROFILES, NoiseProfile, friction_factor, profile
from drakeslip.params import check_count
from drakeslip.units import units_of

from planners.core.particles import NO_FAN, Worlds, fly_particles
from planners.core.robust import RobustAdmission, RobustCheck, aim_particles


LOOKAHEAD_ANGLES = 21  # leg angles tried from each particle's last apex (a fan across the friction cone)
# The last relaxed level's fan: a quarter of the spacing. A soft spring's (k L0 / (m g) near 10) working leg angles
# from a fast apex span a few hundredths of a radian, between the slips and the bottom-outs, which the coarse fan
# steps over; with it, a state the perturbed robots could go on from would be left to the nominal search.
FINE_LOOKAHEAD_ANGLES = 81
# The paper's hopper's margins: where a particle must touch down [m], clear of edges [m], how fast it must go on
LANDING, EDGE_MARGIN, MIN_SPEED = 0.04, 0.01, 0.3
FRICTION_LOSS = 0.05  # the paper's hopper's friction taken off every particle's (its friction error's half-range)


@dataclass(frozen=True)
class Robustness:
    """What a robust sequence must survive: particles at the corners of ``noise`` (``sigmas`` standard
    deviations, half-ranges for the model's uniform errors), a ``friction_loss`` for all of them; where they
    must land; how many hops must work from where the last robust hop leaves them (``lookahead``), among a fan of
    how many leg angles (``lookahead_angles``), each hop the first of how many working hops in a row
    (``lookahead_depth``: 1, the hop alone); how many of a
    sequence's first hops are flown by the particles (``depth``); how many nodes a search at this level may
    expand or refute (``max_nodes``: a robust sequence, when there is one, is found in a few dozen, and proving
    there is none would take thousands); whether a search at this level also tries the planner's fallback grids
    when its coarse grid finds no sequence (``fallback_grids``: at low speed the footholds every particle
    survives lie in bands narrower than the coarse grid's 2.5 cm); what to settle for, in turn, when no sequence
    survives these (``relaxed``: each a dict of the fields that change)."""

    noise: NoiseProfile = PROFILES["realistic"]
    sigmas: float = 2.0
    friction_loss: float | None = None
    landing: float | None = None
    edge_margin: float | None = None
    min_speed: float | None = None
    min_clearance: float = 1.0
    lookahead: int = 2
    lookahead_depth: int = 1
    lookahead_angles: int = LOOKAHEAD_ANGLES
    depth: int = 2
    max_nodes: int = 30
    fallback_grids: bool = False
    relaxed: tuple = ({"depth": 1, "max_nodes": 60},
                      {"depth": 1, "sigmas": 1.0, "max_nodes": 60, "fallback_grids": True},
                      {"depth": 1, "sigmas": 1.0, "max_nodes": 60, "fallback_grids": True,
                       "lookahead_angles": FINE_LOOKAHEAD_ANGLES})

    def __post_init__(self):
        if isinstance(self.noise, dict):
            object.__setattr__(self, "noise", NoiseProfile(**self.noise))
        elif isinstance(self.noise, str):   # a profile by name, as --noise takes one: "realistic*3"
            object.__setattr__(self, "noise", profile(self.noise))
        elif not isinstance(self.noise, NoiseProfile):
            raise ValueError(f"Robustness.noise must be a noise profile (a name such as 'realistic*3', or its "
                             f"fields), got {self.noise!r}")
        for name in ("sigmas", "friction_loss", "landing", "edge_margin", "min_speed", "min_clearance"):
            value = getattr(self, name)
            if value is None and name in ("friction_loss", "landing", "edge_margin", "min_speed"):
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 <= value < math.inf:
                raise ValueError(f"Robustness.{name} must be a non-negative number, got {value!r}")
        if not isinstance(self.fallback_grids, bool):
            raise ValueError(f"Robustness.fallback_grids must be True or False, got {self.fallback_grids!r}")
        object.__setattr__(self, "relaxed", tuple(self.relaxed))
        for level in self.relaxed:
            if not isinstance(level, dict) or "relaxed" in level or "noise" in level:
                raise ValueError(f"Robustness.relaxed must hold dicts of the fields to change (not noise or relaxed), "
                                 f"got {level!r}")
            replace(self, **level, relaxed=())  # checks the level's fields and values
        for name, low in (("lookahead", 0), ("lookahead_depth", 1), ("lookahead_angles", 2), ("depth", 1),
                          ("max_nodes", 1)):
            object.__setattr__(self, name, check_count(getattr(self, name), f"Robustness.{name}", low))

    def levels(self) -> list:
        """This robustness, then each of its ``relaxed`` variants: what a planner asks for in turn when a
        stricter level finds no sequence (made once; a planner asks at every call)."""
        if "_levels" not in self.__dict__:
            object.__setattr__(self, "_levels", (self, *(replace(self, **level, relaxed=()) for level in self.relaxed)))
        return list(self.__dict__["_levels"])

    def particles(self, apex, terrain: Terrain, params: SlipParams) -> "Particles":
        """The perturbed robots at the start ``apex`` over ``terrain`` (the map the planner sees), the nominal
        one first."""
        n, s = self.noise.for_hopper(params), self.sigmas
        none = (0.0, 0.0)
        rows = [(np.zeros(3), 0.0, 1.0, 1.0, none)]
        for axis, sd in enumerate(n.apex):
            for sign in (1.0, -1.0):
                if sd:
                    e = np.zeros(3)
                    e[axis] = sign * s * sd
                    rows.append((e, 0.0, 1.0, 1.0, none))
        for sign in (1.0, -1.0):
            if n.leg_angle:
                rows.append((np.zeros(3), sign * s * n.leg_angle, 1.0, 1.0, none))
            if n.stiffness or n.mass:  # a softer, heavier spring-mass and a stiffer, lighter one
                rows.append((np.zeros(3), 0.0, 1.0 - sign * n.stiffness, 1.0 + sign * n.mass, none))
            if n.heights:  # the ground higher or lower than seen
                rows.append((np.zeros(3), 0.0, 1.0, 1.0, (sign * s * n.heights, 0.0)))
            if n.edges:  # its edges nearer or farther than seen
                rows.append((np.zeros(3), 0.0, 1.0, 1.0, (0.0, sign * s * n.edges)))
        variants = list(dict.fromkeys((ks, ms, g) for *_, ks, ms, g in rows))
        loss = FRICTION_LOSS * friction_factor(params) if self.friction_loss is None else self.friction_loss
        friction = max(params.friction - loss, 1e-3)
        # each world's hopper and terrain as arrays, without making and checking a SlipParams and a Terrain per
        # world: this runs at every search a robust level starts
        hoppers = np.tile(params.as_array(), (len(variants), 1))
        for j, (ks, ms, _) in enumerate(variants):
            hoppers[j, I_STIFFNESS], hoppers[j, I_MASS] = params.stiffness * ks, params.mass * ms
            hoppers[j, I_FRICTION] = friction
        solid = terrain.heights > terrain.ditch_height
        heights = np.stack([np.where(solid, terrain.heights + rise, terrain.heights) for *_, (rise, _) in variants])
        heights.setflags(write=False)   # as a Terrain's: the compiled step map is compiled once, for read-only heights
        worlds = Worlds(hoppers, heights,
                        np.array([terrain.x0 + shift for *_, (_, shift) in variants], dtype=np.float64),
                        float(terrain.cell), float(terrain.ditch_height))
        errors = np.array([e for e, *_ in rows])
        units = units_of(params)
        return Particles(np.asarray(apex, dtype=np.float64) - errors, errors, np.array([d for _, d, *_ in rows]),
                         np.array([variants.index((ks, ms, g)) for *_, ks, ms, g in rows]),
                         np.array([g[1] for *_, g in rows]), worlds,
                         (np.linspace(-0.95, 0.95, self.lookahead_angles) * math.atan(friction))[::-1].copy(),
                         self.min_clearance * params.leg_length, units.length_or(self.landing, LANDING),
                         units.length_or(self.edge_margin, EDGE_MARGIN), units.speed_or(self.min_speed, MIN_SPEED))

    def fly(self, particles: "Particles", foothold: float, controller, terrain: Terrain, last: bool):
        """(robust, the particles' next apexes (P, 3), hops flown) for the candidate ``foothold`` on ``terrain``,
        the map the planner sees, the particles aiming with ``controller`` (a ``StepLengthController``); ``last``:
        this is the last robust hop, so every particle must also have a way on from where it lands. The robust
        admission's own flights (``planners.core.robust``); the next apexes mean something only when robust."""
        check, ground = self.check(particles), terrain.ground()
        angles = aim_particles(check, particles.states, float(foothold), ground, controller.arrays())
        befores = np.zeros((len(particles.states), 4))   # the hops before theirs are not known here
        return fly_particles(check, particles.states, befores, angles, float(foothold), ground,
                             check.fan if last else NO_FAN)

    def check(self, particles: "Particles") -> RobustCheck:
        """``particles`` and what this robustness asks of them, as the robust admission reads them."""
        return RobustCheck(int(self.depth), int(self.lookahead), int(self.lookahead_depth),
                           particles.fan if self.lookahead else NO_FAN, particles.apex_errors,
                           particles.angle_errors, particles.world, particles.shift, particles.worlds,
                           float(particles.clearance), float(particles.landing), float(particles.edge_margin),
                           float(particles.min_speed))

    def admission(self, apex, terrain: Terrain, params: SlipParams, controller, before) -> RobustAdmission:
        """The robust admission of a search from ``apex`` on ``terrain`` for the hopper ``params``, its particles
        aiming with ``controller`` (``ControllerArrays``), reached by the hop ``before``
        (``planners.base.Problem.before``)."""
        particles = self.particles(apex, terrain, params)
        return RobustAdmission(self.check(particles), terrain.ground(), controller, particles.states, before)


@dataclass
class Particles:
    """Perturbed robots flying a sequence together: their true apexes (P, 3), the errors of the apexes they are
    told (P, 3), their leg-angle errors (P,), the world each hops in (P,: an index into ``worlds``, its hopper and
    its terrain) and how far that terrain is shifted from the map (P,); the leg angles of the way-on check (a fan
    across their shared friction cone, most forward first: the hops that work lie forward, so a check that needs a
    few of them stops sooner), how high above the ground their next apexes must be, and the margins of the
    robustness that made them in their hopper's units: how close to the foothold they must land, how far from its
    edges, how fast they must go on."""

    states: np.ndarray
    apex_errors: np.ndarray
    angle_errors: np.ndarray
    world: np.ndarray
    shift: np.ndarray
    worlds: Worlds
    fan: np.ndarray
    clearance: float
    landing: float
    edge_margin: float
    min_speed: float

    def moved(self, states: np.ndarray) -> "Particles":
        """The same robots at new apexes."""
        return replace(self, states=states)

