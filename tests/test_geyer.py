"""Geyer's classic spring-mass runner: the apex return map y[n] -> y[n+1] and its fixed points.

Geyer, Seyfarth & Blickhan (2005): m = 80 kg, L0 = 1 m, dimensionless stiffness k L0 / (m g) = 10.7, angle of
attack 30 deg from vertical (60 deg from the ground), dimensionless energy E / (m g L0) = 1.61 with
E = m g y + m v^2 / 2 (ground at z = 0), so the apex height y fixes the apex speed.

The reference below is independent of drakeslip: stance in polar coordinates about the foot, integrated by
scipy at rtol = atol = 1e-12, with its own flight, touchdown and liftoff logic. With these numbers the map,
taken over every apex height where the leg can touch down (y > L0 cos 30 deg), crosses the diagonal three
times (y ~ 0.877, 0.917, 1.321), but above y ~ 1.226 the runner cannot vault over its foot: its forward
velocity reaches zero in stance and it bounces backwards. Over the forward-running range the map has
exactly two fixed points, a stable one and an unstable one; the backward bounce is a STALL in drakeslip.
"""
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import drakeslip as ds

MASS, LEG, GRAVITY = 80.0, 1.0, 9.81
STIFFNESS = 10.7 * MASS * GRAVITY / LEG
ENERGY = 1.61 * MASS * GRAVITY * LEG
ALPHA = math.radians(30.0)  # from vertical, foot ahead of the body
TOLERANCE = 5e-4  # m
Y_MIN = LEG * math.cos(ALPHA)  # at or below this apex height the foot cannot swing into place
# Geyer's spring has no stroke limit: with drakeslip's default 40 % stroke this soft leg would bottom out above
# y ~ 1.15, so the limit is set out of reach. Friction keeps its default (0.8 > tan 30 deg, never binding here).
PARAMS = ds.SlipParams(mass=MASS, leg_length=LEG, stiffness=STIFFNESS, gravity=GRAVITY, min_leg_length=0.2 * LEG)
FLAT = ds.Terrain.flat()


def apex_speed(y):
    return math.sqrt(2.0 * (ENERGY / MASS - GRAVITY * y))


def reference_return_map(y):
    """Next apex height, or None if the runner does not run on (its forward velocity vanishes in stance,
    or it lifts off moving down)."""
    v = apex_speed(y)
    vz = -math.sqrt(2.0 * GRAVITY * (y - Y_MIN))  # touchdown once the body has dropped to L0 cos(alpha)
    # Body relative to the foot: (-r sin(phi), r cos(phi)); phi = alpha at touchdown.
    rdot = -v * math.sin(ALPHA) + vz * math.cos(ALPHA)
    phidot = -(v * math.cos(ALPHA) + vz * math.sin(ALPHA)) / LEG

    def stance(_, s):
        r, phi, rd, phid = s
        return [rd, phid, r * phid ** 2 - GRAVITY * math.cos(phi) + STIFFNESS / MASS * (LEG - r),
                (GRAVITY * math.sin(phi) - 2.0 * rd * phid) / r]

    def liftoff(_, s):
        return s[0] - LEG

    def forward_velocity(_, s):
        r, phi, rd, phid = s
        return -rd * math.sin(phi) - r * phid * math.cos(phi)

    liftoff.terminal, liftoff.direction = True, 1.0
    forward_velocity.terminal, forward_velocity.direction = True, -1.0
    sol = solve_ivp(stance, (0.0, 10.0), [LEG, ALPHA, rdot, phidot], method="DOP853", rtol=1e-12, atol=1e-12,
                    events=(liftoff, forward_velocity))
    if sol.t_events[0].size == 0:
        return None
    r, phi, rd, phid = sol.y_events[0][0]
    z, zdot = r * math.cos(phi), rd * math.cos(phi) - r * phid * math.sin(phi)
    return z + zdot ** 2 / (2.0 * GRAVITY) if zdot > 0 else None


def backend_return_map(y, backend):
    result = ds.step((0.0, y, apex_speed(y)), ALPHA, FLAT, PARAMS, backend=backend)
    assert result.ok, f"{backend} failed from y={y}: {result.failure}"
    return result.next_apex.z


def reference_fixed_points():
    """Every crossing of the diagonal over the forward-running range, with the map's slope there."""
    ys = np.linspace(Y_MIN + 1e-4, ENERGY / (MASS * GRAVITY) - 1e-3, 120)
    gap = [reference_return_map(y) for y in ys]
    gap = [None if g is None else g - y for g, y in zip(gap, ys)]
    points = []
    for (y0, g0), (y1, g1) in zip(zip(ys, gap), zip(ys[1:], gap[1:])):
        if g0 is not None and g1 is not None and g0 * g1 < 0:
            y_star = brentq(lambda y: reference_return_map(y) - y, y0, y1, xtol=1e-12)
            h = 1e-5
            slope = (reference_return_map(y_star + h) - reference_return_map(y_star - h)) / (2 * h)
            points.append((y_star, slope))
    return points


@pytest.fixture(scope="module")
def fixed_points():
    return reference_fixed_points()


def test_reference_has_one_stable_and_one_unstable_fixed_point(fixed_points):
    assert len(fixed_points) == 2, fixed_points
    (y_stable, slope_stable), (y_unstable, slope_unstable) = fixed_points
    assert abs(slope_stable) < 1 < abs(slope_unstable)
    assert 0.87 < y_stable < y_unstable < 0.93


def test_reference_map_stays_in_range_and_stalls_when_too_slow():
    y_next = reference_return_map(1.0)
    assert Y_MIN < y_next < ENERGY / (MASS * GRAVITY)
    assert reference_return_map(1.3) is None  # where the raw map's third crossing (y ~ 1.32) lies


@pytest.mark.parametrize("backend", ["fast", "drake"])
def test_return_map_matches_reference(backend):
    ys = np.linspace(Y_MIN + 2e-3, 1.22, 12 if backend == "fast" else 4)
    errors = [backend_return_map(y, backend) - reference_return_map(y) for y in ys]
    assert max(map(abs, errors)) < TOLERANCE, dict(zip(ys.round(4), errors))


@pytest.mark.parametrize("backend", ["fast", "drake"])
def test_fixed_points_match_reference(backend, fixed_points):
    for y_ref, _ in fixed_points:
        lo, hi = y_ref - 2e-3, y_ref + 2e-3
        y_star = brentq(lambda y: backend_return_map(y, backend) - y, lo, hi, xtol=1e-7)
        assert abs(y_star - y_ref) < TOLERANCE, (backend, y_star, y_ref)


@pytest.mark.parametrize("backend", ["fast", "drake"])
def test_backward_bounce_is_a_stall(backend):
    result = ds.step((0.0, 1.3, apex_speed(1.3)), ALPHA, FLAT, PARAMS, backend=backend)
    assert result.failure is ds.FailureMode.STALL
