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
robot that replans from there needs a way on. A check is one controller call and one batched step-map call
across the particles' hoppers and terrains (two with the way on).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from drakeslip import SlipParams, Terrain
from drakeslip.noise import PROFILES, NoiseProfile
from drakeslip.params import check_count
from drakeslip.stepmap import Worlds, step_worlds

from planners.search.tree import clear_of_edges

LOOKAHEAD_ANGLES = 21  # leg angles tried from each particle's last apex (a fan across the friction cone)


@dataclass(frozen=True)
class Robustness:
    """What a robust sequence must survive: particles at the corners of ``noise`` (``sigmas`` standard
    deviations, half-ranges for the model's uniform errors), a ``friction_loss`` for all of them; where they
    must land; how many hops must work from where the last robust hop leaves them (``lookahead``); how many of a
    sequence's first hops are flown by the particles (``depth``); how many nodes a search at this level may
    expand or refute (``max_nodes``: a robust sequence, when there is one, is found in a few dozen, and proving
    there is none would take thousands); whether a search at this level also tries the planner's fallback grids
    when its coarse grid finds no sequence (``fallback_grids``: at low speed the footholds every particle
    survives lie in bands narrower than the coarse grid's 2.5 cm); what to settle for, in turn, when no sequence
    survives these (``relaxed``: each a dict of the fields that change)."""

    noise: NoiseProfile = PROFILES["realistic"]
    sigmas: float = 2.0
    friction_loss: float = 0.05
    landing: float = 0.04
    edge_margin: float = 0.01
    min_speed: float = 0.3
    min_clearance: float = 1.0
    lookahead: int = 2
    depth: int = 2
    max_nodes: int = 30
    fallback_grids: bool = False
    relaxed: tuple = ({"depth": 1, "max_nodes": 60},
                      {"depth": 1, "sigmas": 1.0, "max_nodes": 60, "fallback_grids": True})

    def __post_init__(self):
        if isinstance(self.noise, dict):
            object.__setattr__(self, "noise", NoiseProfile(**self.noise))
        for name in ("sigmas", "friction_loss", "landing", "edge_margin", "min_speed", "min_clearance"):
            value = getattr(self, name)
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
        for name, low in (("lookahead", 0), ("depth", 1), ("max_nodes", 1)):
            object.__setattr__(self, name, check_count(getattr(self, name), f"Robustness.{name}", low))

    def levels(self) -> list:
        """This robustness, then each of its ``relaxed`` variants: what a planner asks for in turn when a
        stricter level finds no sequence."""
        return [self] + [replace(self, **level, relaxed=()) for level in self.relaxed]

    def particles(self, apex, terrain: Terrain, params: SlipParams) -> "Particles":
        """The perturbed robots at the start ``apex`` over ``terrain`` (the map the planner sees), the nominal
        one first."""
        n, s = self.noise, self.sigmas
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
        friction = max(params.friction - self.friction_loss, 1e-3)
        worlds = Worlds.of([(Terrain(np.where(terrain.heights > terrain.ditch_height, terrain.heights + rise,
                                              terrain.heights), terrain.cell, terrain.x0 + shift, terrain.ditch_height),
                             replace(params, stiffness=params.stiffness * ks, mass=params.mass * ms, friction=friction))
                            for ks, ms, (rise, shift) in variants])
        errors = np.array([e for e, *_ in rows])
        return Particles(np.asarray(apex, dtype=np.float64) - errors, errors, np.array([d for _, d, *_ in rows]),
                         np.array([variants.index((ks, ms, g)) for *_, ks, ms, g in rows]),
                         np.array([g[1] for *_, g in rows]), worlds, math.atan(friction),
                         self.min_clearance * params.leg_length)

    def fly(self, particles: "Particles", x_l: np.ndarray, controller, terrain: Terrain, last: bool):
        """(robust (k,) bool, next particle states (k, P, 3), step-map calls) for candidate footholds ``x_l`` on
        ``terrain``, the map the planner sees; ``last``: this is the last robust hop, so every particle must also
        have a way on from where it lands. One controller call and one batched step-map call across the
        particles' worlds (two with the way on)."""
        k, n = x_l.size, particles.states.shape[0]
        if k == 0:
            return np.ones(0, dtype=bool), np.zeros((0, n, 3)), 0
        told = particles.states + particles.apex_errors
        aims = controller.leg_angles(np.repeat(told, k, axis=0), np.tile(x_l, n), terrain).reshape(n, k)
        angles = np.clip(aims + particles.angle_errors[:, None], -1.5, 1.5)
        r = step_worlds(np.repeat(particles.states, k, axis=0), angles, particles.worlds,
                        np.repeat(particles.world, k))
        td = r.touchdown_x.reshape(n, k)
        seen = td - particles.shift[:, None]  # where each particle landed on the map the planner sees
        ok = (r.ok.reshape(n, k) & (np.abs(td - x_l) <= self.landing) & (r.next_xdot.reshape(n, k) >= self.min_speed))
        next_x = r.next_x.reshape(n, k)
        aloft = np.isfinite(next_x)
        ok[aloft] &= (r.next_z.reshape(n, k)[aloft] - terrain.height_at((next_x - particles.shift[:, None])[aloft])
                      >= particles.clearance)
        landed = np.isfinite(td)
        ok[landed] &= (terrain.same_level(seen[landed], np.broadcast_to(x_l, td.shape)[landed])
                       & clear_of_edges(terrain, seen[landed], self.edge_margin))
        robust = np.all(ok, axis=0)
        ends = np.stack([r.next_x, r.next_z, r.next_xdot], axis=1).reshape(n, k, 3).transpose(1, 0, 2)
        calls = angles.size
        if last and self.lookahead and robust.any():
            alive = np.flatnonzero(robust)
            fan = np.linspace(-0.95, 0.95, LOOKAHEAD_ANGLES) * particles.friction_angle
            here = ends[alive].reshape(-1, 3)
            world = np.tile(particles.world, alive.size)
            follow = step_worlds(np.repeat(here, fan.size, axis=0), np.tile(fan, here.shape[0]), particles.worlds,
                                 np.repeat(world, fan.size))
            calls += follow.failure.size
            seen = np.nan_to_num(follow.touchdown_x) - np.repeat(particles.shift[world], fan.size)
            good = follow.ok & clear_of_edges(terrain, seen, self.edge_margin) & (follow.next_xdot >= self.min_speed)
            counts = good.reshape(alive.size, n, fan.size).sum(axis=2).min(axis=1)
            robust[alive[counts < self.lookahead]] = False
        return robust, ends, calls


@dataclass
class Particles:
    """Perturbed robots flying a sequence together: their true apexes (P, 3), the errors of the apexes they are
    told (P, 3), their leg-angle errors (P,), the world each hops in (P,: an index into ``worlds``, its hopper and
    its terrain) and how far that terrain is shifted from the map (P,); the friction-cone angle they share."""

    states: np.ndarray
    apex_errors: np.ndarray
    angle_errors: np.ndarray
    world: np.ndarray
    shift: np.ndarray
    worlds: Worlds
    friction_angle: float
    clearance: float

    def moved(self, states: np.ndarray) -> "Particles":
        """The same robots at new apexes."""
        return replace(self, states=states)
