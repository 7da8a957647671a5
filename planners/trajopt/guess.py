"""The initial guess (``build_guess``): the seed's footholds executed by the controller on the fast step map, as
the seed's plan would be, which fixes every decision variable. Where a hop fails or misses its foothold the guess
re-anchors the next apex on the footholds (energy-consistent); the chained guess goes on from that hop's liftoff
instead.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drakeslip import ApexState, SlipParams, Terrain, step_batch
from drakeslip import dynamics as dyn
from drakeslip.fast_step import rk4_step
from drakeslip.units import units_of
from planners.trajopt.config import SEED_TOLERANCE
from planners.trajopt.seeds import default_controller
from planners.trajopt.segments import Segment


@dataclass
class Guess:
    """Values for every decision variable of one N-hop problem (``build_guess`` makes one from footholds).
    ``fast_ok``: the fast step map executes the seed without failure (``fast_failure``: else the first one)."""

    leg_angles: np.ndarray     # (N,)
    fall_times: np.ndarray     # (N,)
    footholds: np.ndarray      # (N,)
    durations: np.ndarray      # (N,) stance
    stance: np.ndarray         # (N, K+1, 4)
    apexes: np.ndarray         # (N+1, 3), apexes[0] the start
    fast_ok: bool = False
    fast_failure: str = ""


def _stance_knots(s0, foot, params: SlipParams, tau: np.ndarray, max_time: float = 1.0):
    """Integrate stance from the touchdown state s0 (RK4 on the shared dynamics.stance_derivatives) until the
    leg is back at rest length; returns (duration, states at the times tau * duration), or None when it never
    lifts off within ``max_time`` (the paper's hopper's seconds, in the hopper's times)."""
    p = params.as_array()
    fx, fz = foot
    L0 = params.leg_length
    units = units_of(params)
    h, max_time = 1e-4 * units.time, max_time * units.time
    s, t = tuple(map(float, s0)), 0.0
    duration = None
    while t < max_time:
        prev, s = s, rk4_step(s, fx, fz, h, p)
        t += h
        l_prev, l_new = dyn.stance_leg_length(prev[0], prev[1], fx, fz), dyn.stance_leg_length(s[0], s[1], fx, fz)
        if not l_new > 0.2 * params.min_leg_length:  # through the foot (or NaN): no stance to speak of
            return None
        if t > 5 * h and l_new >= L0 > l_prev:
            duration = t - h + h * (L0 - l_prev) / (l_new - l_prev)
            break
    if duration is None:
        return None

    def knots(T):
        s = tuple(map(float, s0))
        out = [s]
        for a, b in zip(tau[:-1], tau[1:]):
            for _ in range(20):
                s = rk4_step(s, fx, fz, (b - a) * T / 20, p)
            out.append(s)
        return np.array(out)

    path = knots(duration)
    for _ in range(2):  # Newton on the liftoff time: the leg exactly at rest length at the last knot
        x, z, xd, zd = path[-1]
        rate = dyn.leg_rate(x, z, xd, zd, fx, fz)
        if rate <= 0:
            break
        duration -= (dyn.stance_leg_length(x, z, fx, fz) - L0) / rate
        path = knots(duration)
    return duration, path


def _plausible(knots_out, foot, params: SlipParams) -> bool:
    """A stance guess worth starting from: it lifts off upward and forward, never stops or bottoms out."""
    if knots_out is None:
        return False
    duration, path = knots_out
    if not (np.all(np.isfinite(path)) and math.isfinite(duration)):
        return False
    legs = np.hypot(path[:, 0] - foot[0], path[:, 1] - foot[1])
    slow = 0.05 * units_of(params).speed
    return bool(path[-1, 3] > slow and np.all(path[:, 2] > slow) and legs.min() > params.min_leg_length
                and duration < 3 * math.pi / params.natural_frequency)


def _symmetric_stance(s0, foot, tau: np.ndarray, params: SlipParams):
    """A fallback stance guess: the touchdown state mirrored about the foot, a straight line between."""
    x, z, xd, zd = s0
    s1 = np.array([2 * foot[0] - x, z, xd, -zd])
    duration = math.pi / params.natural_frequency
    u = tau[:, None]
    return duration, (1 - u) * np.asarray(s0) + u * s1


def build_guess(apex, footholds, segs: list[Segment], terrain: Terrain, params: SlipParams,
                tau: np.ndarray, controller=None, reanchor: bool = True) -> Guess:
    """Execute the footholds as the seed's plan would be: at every apex the controller's leg angle for the next
    foothold, the hop on the fast step map (whose next apex the guess takes). Stance knots (at the times
    ``tau``, fractions of the stance) come from integrating the shared stance equations from the touchdown on
    the assigned segment; flight is closed form.

    A hop that fails on the fast step map, or lands more than SEED_TOLERANCE from its foothold, would leave
    the rest of the chain meaningless (a hop that nearly stalls sends the next one anywhere). The guess keeps
    that hop's stance (integrated, or a symmetric one where it stalls or bottoms out) and re-anchors the next
    apex: midway between the two footholds, as high above the higher of their segments as the start was above
    its ground, and as fast as the start's energy allows there (the SLIP conserves energy). With
    ``reanchor=False`` the chain goes on from that hop's liftoff instead. Lengths and speeds here are the paper's
    hopper's in the hopper's units."""
    controller = (controller or default_controller()).for_params(params)
    L0, g = params.leg_length, params.gravity
    units = units_of(params)
    apex = ApexState(*map(float, apex))
    footholds = np.asarray(footholds, dtype=np.float64)
    n = footholds.size
    angles, falls, durs, feet = np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n)
    stance = np.zeros((n, tau.size, 4))
    apexes = np.zeros((n + 1, 3))
    apexes[0] = apex
    limit = 0.97 * math.atan(params.friction)
    energy = g * apex.z + 0.5 * apex.xdot ** 2                       # per unit mass
    above = max(apex.z - terrain.height_at(apex.x), L0 + 0.15 * units.length)   # apex height above the ground
    fast_ok, fast_failure = True, ""
    for i in range(n):
        a = ApexState(*apexes[i])
        h = segs[i].height
        theta = float(np.clip(controller.leg_angle(a, footholds[i], terrain), -limit, limit))
        tf = math.sqrt(2 * max(a.z - L0 * math.cos(theta) - h, 1e-6) / g)
        s0 = np.array([a.x + a.xdot * tf, h + L0 * math.cos(theta), a.xdot, -g * tf])
        foot = (s0[0] + L0 * math.sin(theta), h)
        knots_out = _stance_knots(s0, foot, params, tau)
        hop = step_batch(apexes[i], [theta], terrain, params).result(0)
        lands = hop.ok and abs(hop.touchdown_x - footholds[i]) < SEED_TOLERANCE * units.length
        if lands and knots_out is not None:
            # a hop the fast step map executes: its stance is the integrated one, its apex the step map's
            angles[i], falls[i], durs[i], feet[i], stance[i] = theta, tf, knots_out[0], foot[0], knots_out[1]
            apexes[i + 1] = hop.next_apex
            continue
        if fast_ok:
            fast_ok = False
            fast_failure = (f"hop {i}: {hop.failure.name}" if not hop.ok else
                            f"hop {i}: lands at x={hop.touchdown_x:.3f}, not {footholds[i]:.3f}")
        if not _plausible(knots_out, foot, params):  # the hop fails in stance: guess a symmetric one instead
            knots_out = _symmetric_stance(s0, foot, tau, params)
        dur, path = knots_out
        angles[i], falls[i], durs[i], feet[i], stance[i] = theta, tf, dur, foot[0], path
        apexes[i + 1] = (_reanchored_apex(i, footholds, segs, a.x, above, energy, params) if reanchor
                         else _apex_after_liftoff(path[-1], params))
    return Guess(angles, falls, feet, durs, stance, apexes, fast_ok, fast_failure)


def _apex_after_liftoff(liftoff, params: SlipParams) -> tuple:
    """The apex of the flight from the ``liftoff`` state (x, z, xdot, zdot), its speeds held to at least the
    paper's hopper's 5 cm/s (up and forward)."""
    slow, g = 0.05 * units_of(params).speed, params.gravity
    zd, xd = max(liftoff[3], slow), max(liftoff[2], slow)
    return (liftoff[0] + xd * zd / g, liftoff[1] + zd * zd / (2 * g), xd)


def _reanchored_apex(i: int, footholds: np.ndarray, segs: list[Segment], x: float, above: float, energy: float,
                     params: SlipParams) -> tuple:
    """The apex after hop i (from an apex at ``x``) re-anchored on the seed's footholds: midway between footholds
    i and i + 1 (past the last, one more step as long as the one before), ``above`` the higher of their segments,
    and as fast as the start's ``energy`` per unit mass allows there."""
    n, g, units = footholds.size, params.gravity, units_of(params)
    h = segs[i].height
    nxt = footholds[i + 1] if i + 1 < n else footholds[i] + (footholds[i] - (footholds[i - 1] if i else x))
    top = max(h, segs[i + 1].height if i + 1 < n else h)
    z = top + above
    v = min(max(math.sqrt(max(2 * (energy - g * z), 0.0)), 0.5 * units.speed), 3.5 * units.speed)
    return (0.5 * (footholds[i] + nxt), z, v)

