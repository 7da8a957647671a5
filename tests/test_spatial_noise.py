"""Noise on height maps (drakeslip.spatial.noise, planners.spatial_loop): the 3D draws follow the profile's sizes in
the hopper's units and are seeded by the case, the perceived map keeps its holes and moves in x and y, the robot's
median filter is the planar one on a grid, the loop draws in the planar order and still reaches the goal, and the
planar draws are what they were."""
import numpy as np
import pytest

import drakeslip as ds
import planners
from drakeslip.noise import PROFILES, profile
from drakeslip.spatial.controller import leg_angles_for
from drakeslip.spatial.heightmap import HeightMap
from drakeslip.spatial.noise import angle_errors3d, apex_errors3d, apex_sizes3d, denoised_map, perceived_map
from drakeslip.units import units_of
from planners.replanning import ClosedLoopConfig, case_seed, drawn_hopper
from planners.spatial_loop import MapCase, MapLoop, perception_window, run_map_case
from test_spatial_planners import START, walled_map

P = ds.SlipParams()
REALISTIC = PROFILES["realistic"]
NOISY = ClosedLoopConfig(backend="fast", executed_per_plan=1, noise=REALISTIC)


def strip(result):
    """A result without its timings (the only thing that differs between two runs of a case)."""
    return {**result, "plans": [{k: v for k, v in p.items() if k not in ("t_plan_s", "timing")}
                                for p in result["plans"]]}


@pytest.fixture(scope="module")
def step_planner():
    return planners.make("step")


def test_the_planar_draws_are_unchanged():
    """What ``realistic`` drew from seed 1 before the spatial draws existed: the planar tables stay per case."""
    rng = np.random.default_rng(1)
    assert REALISTIC.apex_errors(rng, 3).tolist() == [
        [0.0017279209603239302, 0.004108090717505792, 0.006608741523667742],
        [-0.006515786158021805, 0.0045267793333655885, 0.008927491447280226],
        [-0.002684766176801426, 0.0029055905209817655, 0.007291447923721515]]
    assert REALISTIC.angle_errors(rng, 3).tolist() == [0.00147066248327763, 0.00014211120657898395,
                                                       0.0027335649330622346]
    executed = REALISTIC.executed_params(P, rng)
    assert (executed.mass, executed.stiffness, executed.friction) == (7.080760036959954, 3178.205659711884,
                                                                      0.7803194829291645)


def test_the_3d_draws_have_the_profiles_sizes_in_the_hoppers_units():
    rng = np.random.default_rng(0)
    apex = apex_errors3d(REALISTIC, rng, 40_000)
    np.testing.assert_allclose(apex.std(axis=0), (0.005, 0.005, 0.005, 0.02, 0.02), rtol=0.03)
    assert abs(np.corrcoef(apex[:, 0], apex[:, 1])[0, 1]) < 0.03   # x and y: two draws
    angles = angle_errors3d(REALISTIC, rng, 40_000)
    np.testing.assert_allclose(angles.std(axis=0), (0.005, 0.005), rtol=0.03)
    assert abs(np.corrcoef(angles.T)[0, 1]) < 0.03                  # pitch and roll: two draws
    small = ds.SlipParams(mass=3.0, leg_length=0.3, stiffness=981.0, friction=0.6)
    speed = units_of(small).speed
    np.testing.assert_allclose(apex_sizes3d(REALISTIC.for_hopper(small)),
                               (0.003, 0.003, 0.003, 0.02 * speed, 0.02 * speed))
    assert angle_errors3d(REALISTIC.for_hopper(small), np.random.default_rng(2), 1).tolist() == \
        angle_errors3d(REALISTIC, np.random.default_rng(2), 1).tolist()   # radians: the same for any hopper
    assert not apex_errors3d(PROFILES["actuation"], rng, 3).any() and not angle_errors3d(PROFILES["state"], rng, 3).any()


def test_the_perceived_map_keeps_its_holes_and_moves_in_x_and_y():
    h = np.zeros((200, 200))
    h[:, 100:120] = np.nan   # a band across x ...
    h[150:160, :] = np.nan   # ... and one across y
    height_map = HeightMap(h, 0.05, (-5.0, -5.0))
    seen = perceived_map(REALISTIC, height_map, np.random.default_rng(3))
    holes = np.isnan(h)
    assert np.array_equal(np.isnan(seen.heights), holes)
    assert 0.0097 < np.std(seen.heights[~holes]) < 0.0103 and abs(np.mean(seen.heights[~holes])) < 2e-4
    dx, dy = np.subtract(seen.origin, height_map.origin)
    assert dx != 0 and dy != 0 and seen.cell == height_map.cell
    edge = -5.0 + 100 * 0.05   # the band's near edge, moved by dx in the map seen
    assert not seen.is_hole_at(edge + dx - 1e-3, 0.0) and seen.is_hole_at(edge + dx + 1e-3, 0.0)
    edge = -5.0 + 150 * 0.05   # the other band's near edge, moved by dy
    assert not seen.is_hole_at(-4.0, edge + dy - 1e-3) and seen.is_hole_at(-4.0, edge + dy + 1e-3)
    shifts = np.array([np.subtract(perceived_map(REALISTIC, height_map, np.random.default_rng(s)).origin,
                                   height_map.origin) for s in range(400)])
    assert np.all(np.abs(shifts.std(axis=0) - 0.01) < 0.0015) and abs(np.corrcoef(shifts.T)[0, 1]) < 0.15
    window = height_map.window(-1.0, 1.0, -1.0, 1.0)
    assert not perceived_map(REALISTIC, window, np.random.default_rng(0)).extends_flat


def test_the_median_filter_restores_levels_and_cuts_noise():
    x = np.arange(60)
    stairs = np.tile(np.where(x < 20, 0.0, np.where(x < 40, 0.1, -0.05)), (30, 1))
    stairs[10:14, 25:35] = np.nan
    staircase = HeightMap(stairs, 0.05)
    assert np.array_equal(denoised_map(staircase, 0.01, 5).heights, stairs, equal_nan=True)
    flat = HeightMap.flat(size=(10.0, 10.0), cell=0.05)
    rms = {k: np.sqrt(np.mean(perceived_map(profile("terrain"), flat, np.random.default_rng(4), k).heights ** 2))
           for k in (1, 3, 5)}
    assert 0.0095 < rms[1] < 0.0105 and rms[3] < 0.6 * rms[1] and rms[5] < 0.45 * rms[1]
    assert denoised_map(flat, 0.0, 5) is flat and denoised_map(flat, 0.01, 1) is flat
    # one row is the planar terrain: the filter there is ``Terrain.denoised``
    solid = x % 17 >= 3
    sensed = 0.02 * (x // 10) + 0.01 * np.random.default_rng(5).normal(size=60)
    terrain = ds.Terrain(np.where(solid, sensed, ds.Terrain.flat().ditch_height), 0.05, -1.0)
    row = HeightMap(np.where(solid, terrain.heights, np.nan)[None], 0.05, (-1.0, 0.0))
    assert np.array_equal(denoised_map(row, 0.01, 5).heights[0][solid], terrain.denoised(0.01, 5).heights[solid])


def test_the_loop_draws_in_the_planar_order(step_planner):
    """The executed hopper, then per planning call the k apex errors, the k angle errors, the map: the plan is told
    the noisy apex and the leg reaches the angles aimed from it plus their errors."""
    case, k = MapCase("walled-0", walled_map(), START, (7.0, 0.0)), 2
    loop = MapLoop(step_planner, case, P, ClosedLoopConfig(backend="fast", executed_per_plan=k, noise=REALISTIC))
    command = loop.command(START, 0)
    rng = np.random.default_rng(case_seed(0, case.id))
    assert drawn_hopper(REALISTIC, P, rng) == loop.executed != P
    apex_errors, angle_errors = apex_errors3d(REALISTIC, rng, k), angle_errors3d(REALISTIC, rng, k)
    record = loop.plans[0]
    seen = np.add(START, apex_errors[0])
    assert record["seen_apex"] == seen.tolist() and record["apex"] == list(START)
    aimed = leg_angles_for(seen, record["executed"][0], P)
    assert np.array_equal(command, np.add(aimed, angle_errors[0]))
    goal = loop.aim
    window = perception_window(case.terrain, seen, goal, P)
    perceived_map(REALISTIC, window, rng)
    assert rng.normal() == loop.rng.normal()   # the map was the call's last draw
    assert goal[0] == pytest.approx(7.0 + 5 * 0.005) and goal[1] == pytest.approx(0.0)


def test_noisy_cases_repeat_under_their_seed(step_planner):
    run = lambda case_id, config=NOISY: strip(run_map_case(step_planner, MapCase(case_id, walled_map(), START,
                                                                                 (7.0, 0.0)), P, config)[0])
    first = run("walled-1")
    assert first == run("walled-1")
    assert first["plans"][0]["seen_apex"] != run("walled-2")["plans"][0]["seen_apex"]
    assert first["plans"][0]["seen_apex"] != run("walled-1", ClosedLoopConfig(
        backend="fast", executed_per_plan=1, noise=REALISTIC, seed=1))["plans"][0]["seen_apex"]


@pytest.mark.parametrize("backend", ["fast", "drake"])
def test_a_silent_profile_is_the_noiseless_loop(step_planner, backend):
    case = MapCase("walled", walled_map(), START, (7.0, 0.0))
    plain, _ = run_map_case(step_planner, case, P, ClosedLoopConfig(backend=backend))
    silent, _ = run_map_case(step_planner, case, P, ClosedLoopConfig(backend=backend, noise=profile("realistic*0"),
                                                                      seed=5))
    assert plain["success"] and strip(plain) == strip(silent) and "executed_params" not in plain
    assert all("seen_apex" not in p for p in plain["plans"])


def test_the_loop_reaches_the_goal_round_a_wall_under_realistic_noise(step_planner):
    results = [run_map_case(step_planner, MapCase(f"walled-{i}", walled_map(), START, (7.0, 0.0)), P, NOISY)[0]
               for i in range(6)]
    assert sum(r["success"] for r in results) >= 4, [r["failure"] for r in results]
    for result in results:
        executed = ds.SlipParams(**result["executed_params"])
        assert executed != P and executed.leg_length == P.leg_length
        assert all(p["seen_apex"] != p["apex"] for p in result["plans"])
