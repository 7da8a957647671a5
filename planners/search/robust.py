"""Children that survive noise: every hop of a sequence's first ``depth`` is flown by a set of perturbed robots
(particles) at once, and kept only if all of them make it and can go on from where they land.

The planner believes the hopper is at apex ``a``. A real robot is somewhere near ``a`` (state estimation), its
leg reaches the controller's angle give or take (actuation), its spring and mass are not quite the model's and
the ground's friction is uncertain (model mismatch), and the ground is not quite where the map says
(perception). Each particle is one such robot: it starts from ``a - e`` and is told it is ``e`` off where it is at
every apex (its estimate is biased by ``e``), adds ``d`` to every leg angle the controller gives it, hops with its own stiffness and mass over the map raised or shifted by its own terrain
error, and with a friction ``friction_loss`` below the model's. The errors are the corners of the noise box
(each at +-``sigmas`` standard deviations of ``noise``, or its half-range for the model's uniform errors, one at
a time), so the search stays deterministic.

Expanding a node, every particle aims at each candidate foothold with the controller from the apex it is told (as
the robot would, executing a plan's footholds) and hops; a candidate is robust when every particle completes the
hop, touches down within ``landing`` of the foothold on the same level, clear of its edges by ``edge_margin``,
and keeps ``min_speed`` at its next apex; the child's particles are those next apexes. At the last robust hop
every particle must also find at least ``lookahead`` working hops in a fan of leg angles from where it lands: a
robot that replans from there needs a way on. Particles are flown only for candidates that work nominally, in
one controller call and one batched step-map call per hopper and terrain variant.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from drakeslip import SlipParams, Terrain, step_batch
from drakeslip.noise import PROFILES, NoiseProfile
from drakeslip.params import check_count

from planners.search.tree import clear_of_edges

LOOKAHEAD_ANGLES = 21  # leg angles tried from each particle's last apex (a fan across the friction cone)


@dataclass(frozen=True)
class Robustness:
    """What a robust sequence must survive: particles at the corners of ``noise`` (``sigmas`` standard
    deviations, half-ranges for the model's uniform errors), a ``friction_loss`` for all of them; where they
    must land; how many hops must work from where the last robust hop leaves them (``lookahead``); how many of a
    sequence's first hops are flown by the particles (``depth``); what to settle for, in turn, when no sequence
    survives these (``relaxed``: each a dict of the fields that change)."""

    noise: NoiseProfile = PROFILES["realistic"]
    sigmas: float = 2.0
    friction_loss: float = 0.05
    landing: float = 0.04
    edge_margin: float = 0.01
    min_speed: float = 0.3
    lookahead: int = 2
    depth: int = 3
    relaxed: tuple = ({"depth": 1}, {"depth": 1, "sigmas": 1.0})

    def __post_init__(self):
        if isinstance(self.noise, dict):
            object.__setattr__(self, "noise", NoiseProfile(**self.noise))
        for name in ("sigmas", "friction_loss", "landing", "edge_margin", "min_speed"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 <= value < math.inf:
                raise ValueError(f"Robustness.{name} must be a non-negative number, got {value!r}")
        object.__setattr__(self, "relaxed", tuple(self.relaxed))
        for level in self.relaxed:
            if not isinstance(level, dict) or "relaxed" in level or "noise" in level:
                raise ValueError(f"Robustness.relaxed must hold dicts of the fields to change (not noise or relaxed), "
                                 f"got {level!r}")
            replace(self, **level, relaxed=())  # checks the level's fields and values
        for name, low in (("lookahead", 0), ("depth", 1)):
            object.__setattr__(self, name, check_count(getattr(self, name), f"Robustness.{name}", low))

    def levels(self) -> list:
        """This robustness, then each of its ``relaxed`` variants: what a planner asks for in turn when a
        stricter level finds no sequence."""
        return [self] + [replace(self, **level, relaxed=()) for level in self.relaxed]

    def particles(self, apex) -> "Particles":
        """The perturbed robots at the start ``apex``: the nominal one first."""
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
        errors = np.array([e for e, *_ in rows])
        return Particles(np.asarray(apex, dtype=np.float64) - errors, errors, np.array([d for _, d, *_ in rows]),
                         [(ks, ms, g) for _, _, ks, ms, g in rows])

    def fly(self, particles: "Particles", x_l: np.ndarray, controller, terrain: Terrain, params: SlipParams,
            last: bool):
        """(robust (k,) bool, next particle states (k, P, 3), step-map calls) for candidate footholds ``x_l``;
        ``last``: this is the last robust hop, so every particle must also have a way on from where it lands."""
        k, n = x_l.size, particles.states.shape[0]
        robust = np.ones(k, dtype=bool)
        ends = np.zeros((k, n, 3))
        if k == 0:
            return robust, ends, 0
        told = particles.states + particles.apex_errors
        aims = controller.leg_angles(np.repeat(told, k, axis=0), np.tile(x_l, n), terrain).reshape(n, k)
        calls = 0
        for (ks, ms, (rise, shift)), rows in particles.groups().items():
            hopper = replace(params, stiffness=params.stiffness * ks, mass=params.mass * ms,
                             friction=max(params.friction - self.friction_loss, 1e-3))
            world = terrain if not (rise or shift) else Terrain(
                np.where(terrain.heights > terrain.ditch_height, terrain.heights + rise, terrain.heights),
                terrain.cell, terrain.x0 + shift, terrain.ditch_height)
            starts = np.repeat(particles.states[rows], k, axis=0)
            angles = np.clip(aims[rows] + particles.angle_errors[rows, None], -1.5, 1.5).reshape(-1)
            r = step_batch(starts, angles, world, hopper)
            calls += angles.size
            td = r.touchdown_x.reshape(len(rows), k)
            ok = (r.ok.reshape(len(rows), k) & (np.abs(td - x_l) <= self.landing)
                  & (r.next_xdot.reshape(len(rows), k) >= self.min_speed))
            landed = np.isfinite(td)
            ok[landed] &= world.same_level(td[landed], np.broadcast_to(x_l + shift, td.shape)[landed]) \
                & clear_of_edges(world, td[landed], self.edge_margin)
            robust &= np.all(ok, axis=0)
            nxt = np.stack([r.next_x, r.next_z, r.next_xdot], axis=1).reshape(len(rows), k, 3)
            ends[:, rows] = nxt.transpose(1, 0, 2)
            if last and self.lookahead and robust.any():
                alive = np.flatnonzero(robust)
                fan = np.linspace(-0.95, 0.95, LOOKAHEAD_ANGLES) * np.arctan(hopper.friction)
                here = nxt[:, alive].reshape(-1, 3)
                follow = step_batch(np.repeat(here, fan.size, axis=0), np.tile(fan, here.shape[0]), world, hopper)
                calls += follow.failure.size
                good = follow.ok & clear_of_edges(world, np.nan_to_num(follow.touchdown_x), self.edge_margin) \
                    & (follow.next_xdot >= self.min_speed)
                counts = good.reshape(len(rows), alive.size, fan.size).sum(axis=2).min(axis=0)
                robust[alive[counts < self.lookahead]] = False
        return robust, ends, calls


@dataclass
class Particles:
    """Perturbed robots flying a sequence together: their true apexes (P, 3), the errors of the apexes they are
    told (P, 3), their leg-angle errors (P,), and each one's (stiffness factor, mass factor, terrain (rise,
    shift))."""

    states: np.ndarray
    apex_errors: np.ndarray
    angle_errors: np.ndarray
    variants: list

    def groups(self) -> dict:
        """Particle indices by hopper and terrain variant (one batched step-map call each)."""
        out: dict = {}
        for i, v in enumerate(self.variants):
            out.setdefault(v, []).append(i)
        return {v: np.array(rows) for v, rows in out.items()}

    def moved(self, states: np.ndarray) -> "Particles":
        """The same robots at new apexes."""
        return Particles(states, self.apex_errors, self.angle_errors, self.variants)
