"""Every FailureMode, triggered by a hand-built hop, reported identically by both backends."""
import math

import numpy as np
import pytest

import drakeslip as ds
from drakeslip import FailureMode

PARAMS = ds.SlipParams()  # 7 kg, 0.5 m leg, 3200 N/m, mu 0.8 (atan 0.8 = 0.675 rad), bottoms out at 0.3 m
FLAT = ds.Terrain.flat()


def blocks(*spans, base=0.0):
    """Flat ground at ``base`` with (x_from, x_to, height) blocks, on the default 10 cm grid."""
    terrain = ds.Terrain.flat(base)
    heights = terrain.heights.copy()
    for x_from, x_to, height in spans:
        heights[round((x_from - terrain.x0) / terrain.cell):round((x_to - terrain.x0) / terrain.cell)] = height
    return ds.Terrain(heights, terrain.cell, terrain.x0)


def touchdown_time(apex, angle, params=PARAMS):
    """Time for the extended foot to fall from apex to flat ground at z = 0."""
    return math.sqrt(2 * (apex[1] - params.leg_length * math.cos(angle)) / params.gravity)


# name: (apex, leg angle, terrain, params, expected failure)
CASES = {
    # Apex too low for the angle: the foot would have to be swung through the ground.
    "trip_low_apex": ((0.0, 0.4, 1.0), 0.2, FLAT, PARAMS, FailureMode.TRIP),
    # A block ahead reaches above the commanded foot position.
    "trip_block_under_foot": ((0.0, 0.6, 1.0), 0.3, blocks((0.1, 0.4, 0.3)), PARAMS, FailureMode.TRIP),
    # The falling foot (z 0.12 at x 0.15) meets the 0.15 m face of a step at x = 0.3.
    "foot_hits_wall": ((0.0, 0.6, 2.0), 0.3, blocks((0.3, 5.0, 0.15)), PARAMS, FailureMode.FOOT_COLLISION),
    # The foot would land at x ~ 0.43 on flat ground; here it drops into a ditch (0.3-0.6) and strikes its far wall.
    "foot_into_ditch_wall": ((0.0, 0.6, 2.0), 0.25, blocks((0.3, 0.6, -1.0)), PARAMS, FailureMode.FOOT_COLLISION),
    # Slowly over a wide ditch the foot reaches the ditch floor: a ditch landing is a FOOT_COLLISION too.
    "foot_on_ditch_floor": ((0.0, 0.6, 0.5), 0.25, blocks((0.1, 0.7, -1.0)), PARAMS, FailureMode.FOOT_COLLISION),
    # Leg swung back, body flies into the face of a block taller than itself before the foot lands.
    "body_hits_wall": ((0.0, 0.6, 2.0), -0.3, blocks((0.3, 5.0, 0.7)), PARAMS, FailureMode.BODY_COLLISION),
    # Leg swung back, the foot lands before a 0.45 m block; in stance the body comes down on the block's top.
    "body_hits_block_in_stance": ((0.0, 0.6, 2.0), -0.3, blocks((0.3, 5.0, 0.45)), PARAMS,
                                  FailureMode.BODY_COLLISION),
    # Touchdown angle beyond atan(mu).
    "slip_at_touchdown": ((0.0, 0.7, 1.0), 0.75, FLAT, PARAMS, FailureMode.SLIP),
    # A normal angle on ice.
    "slip_low_friction": ((0.0, 0.6, 2.0), 0.25, FLAT, PARAMS.with_friction(0.2), FailureMode.SLIP),
    # Inside the cone at touchdown, but a fast body vaults far past the foot and leaves it mid-stance.
    "slip_mid_stance": ((0.0, 0.6, 4.0), 0.1, FLAT, PARAMS, FailureMode.SLIP),
    # A 1.5 m drop stores more than the 64 J the 0.2 m stroke can take.
    "bottom_out_big_drop": ((0.0, 2.0, 1.0), 0.1, FLAT, PARAMS, FailureMode.BOTTOM_OUT),
    # An ordinary hop on a soft spring.
    "bottom_out_soft_spring": ((0.0, 0.6, 1.5), 0.2, FLAT, ds.SlipParams(stiffness=500.0), FailureMode.BOTTOM_OUT),
    # Steep angle at walking speed: the body cannot vault over the foot and falls back (xdot reaches 0).
    "stall_falls_back": ((0.0, 0.6, 0.3), 0.3, FLAT, PARAMS, FailureMode.STALL),
    # Leg straight down at high speed: the spring rebounds while the body still moves down, no apex follows.
    "stall_no_apex_after_liftoff": ((0.0, 0.55, 5.0), 0.0, FLAT, PARAMS, FailureMode.STALL),
}


def test_every_failure_mode_of_the_model_has_a_case():
    assert {case[-1] for case in CASES.values()} == set(FailureMode) - {FailureMode.TIMEOUT}


def test_a_hop_past_the_drake_limit_is_a_timeout_not_a_stall():
    """A fall into a 200 m pit lasts 6.4 s, past the 5 s per-hop limit of the paper's hopper: Drake cuts the run
    with the body still falling (a TIMEOUT, not a guard of the model); the fast backend has no limit and reaches
    the pit's floor, where the spring bottoms out."""
    heights = blocks((0.0, 20.0, -200.0)).heights
    pit = ds.Terrain(heights, 0.1, -3.0, ditch_height=-300.0)   # solid ground 200 m down, not a ditch
    drake = ds.step((0.5, 0.9, 1.0), 0.1, pit, PARAMS, backend="drake")
    assert drake.failure is FailureMode.TIMEOUT and drake.time == pytest.approx(5.0, abs=0.01)
    assert -200.0 < drake.end_state[1] < 0.0 and drake.end_state[3] < -40.0   # falling at about 49 m/s
    fast = ds.step((0.5, 0.9, 1.0), 0.1, pit, PARAMS, backend="fast")
    assert fast.failure is FailureMode.BOTTOM_OUT and fast.time > 6.0


@pytest.mark.parametrize("backend", ["fast", "drake"])
@pytest.mark.parametrize("name", list(CASES))
def test_failure_mode(name, backend):
    apex, angle, terrain, params, expected = CASES[name]
    result = ds.step(apex, angle, terrain, params, backend=backend)
    assert result.failure is expected, f"{name} on {backend}: {result}"
    assert not result.ok and result.next_apex is None
    assert np.all(np.isfinite(result.end_state))


@pytest.mark.parametrize("backend", ["fast", "drake"])
def test_failure_time_and_place(backend):
    """Failures are reported where they happen: a mid-stance slip or body collision after touchdown, a trip
    at once, a wall strike with the foot at the wall, a ditch landing with the foot on the ditch floor."""
    apex, angle, terrain, params, _ = CASES["slip_mid_stance"]
    slip = ds.step(apex, angle, terrain, params, backend=backend)
    assert slip.time > touchdown_time(apex, angle) + 0.02
    assert slip.end_state[0] > slip.touchdown_x  # the body is past its foot
    trip = ds.step(*CASES["trip_low_apex"][:4], backend=backend)
    assert trip.time == 0.0 and math.isnan(trip.touchdown_x)
    apex, angle, terrain, params, _ = CASES["foot_hits_wall"]
    wall = ds.step(apex, angle, terrain, params, backend=backend)
    foot_x = wall.end_state[0] + params.leg_length * math.sin(angle)
    assert foot_x == pytest.approx(0.3, abs=1e-6)
    apex, angle, terrain, params, _ = CASES["foot_on_ditch_floor"]
    floor = ds.step(apex, angle, terrain, params, backend=backend)
    assert floor.end_state[1] - params.leg_length * math.cos(angle) == pytest.approx(-1.0, abs=1e-6)
    block = ds.step(*CASES["body_hits_block_in_stance"][:4], backend=backend)
    assert block.touchdown_x < 0.3 <= block.end_state[0]
    assert block.end_state[1] == pytest.approx(0.45, abs=1e-6)


@pytest.mark.parametrize("backend", ["fast", "drake"])
def test_success(backend):
    apex, angle = (0.0, 0.6, 2.0), 0.25
    result = ds.step(apex, angle, FLAT, PARAMS, backend=backend)
    assert result.ok and result.failure is None
    foothold = apex[0] + PARAMS.leg_length * math.sin(angle) + apex[2] * touchdown_time(apex, angle)
    assert result.touchdown_x == pytest.approx(foothold, abs=1e-6)
    assert result.next_apex.x > result.touchdown_x
    assert result.next_apex.z > PARAMS.leg_length  # room to swing the leg for the next hop
