"""Noise in the protocol (drakeslip.noise, planners.closed_loop) and planners that keep margins against it
(planners.search.robust): profiles are checked and scale, noiseless runs are today's protocol, noisy runs are
repeatable under a seed, and the robust preset's plan survives noise that the nominal plan does not."""
from dataclasses import replace

import numpy as np
import pytest

import drakeslip as ds
import planners
from drakeslip.controller import StepLengthController
from drakeslip.noise import PROFILES, NoiseProfile, profile
from drakeslip.units import units_of
from planners.closed_loop import ClosedLoopConfig, run_case
from planners.formats.plan import PlanRecord
from planners.formats.suite import make_suite
from planners.search.robust import Robustness
from verification.robustness import success_probability


@pytest.fixture(scope="module")
def controller():
    return StepLengthController.load_default()


def test_profiles_scale_and_name_their_bad_values():
    realistic = PROFILES["realistic"]
    assert realistic.apex == (0.005, 0.005, 0.02) and realistic.leg_angle == 0.005
    assert profile("realistic*0.5") == realistic.scaled(0.5)
    assert profile("realistic*0").silent and profile("none").silent and not realistic.silent
    assert profile("realistic*2").heights == pytest.approx(0.02)
    assert NoiseProfile(apex=(np.float32(0.01), 0, 0)).apex[0] == pytest.approx(0.01)
    for spec, message in (("gaussian", "unknown noise profile 'gaussian'"), ("realistic*x", "must be a number"),
                          ("realistic*-1", "finite number >= 0"), ("realistic*inf", "finite number >= 0"),
                          ("realistic*1e9", r"noise 'realistic\*1e9': .* got stiffness 2e\+07 and mass 2e\+07$")):
        with pytest.raises(ValueError, match=message):
            profile(spec)
    for kwargs, message in ((dict(leg_angle=-0.1), "must not be negative, got leg_angle -0.1$"),
                            (dict(apex=(0, 0)), "apex must be"),
                            (dict(stiffness=1.0), "below 1"), (dict(heights=float("nan")), "heights"),
                            (dict(mass=True), "mass")):
        with pytest.raises(ValueError, match=message):
            NoiseProfile(**kwargs)


def test_draws_follow_the_profile():
    rng = np.random.default_rng(0)
    noise = PROFILES["realistic"]
    errors = noise.apex_errors(rng, 20_000)
    np.testing.assert_allclose(errors.std(axis=0), noise.apex, rtol=0.03)
    hopper = [noise.executed_params(ds.SlipParams(), rng) for _ in range(2000)]
    stiffness = np.array([h.stiffness for h in hopper]) / ds.SlipParams().stiffness - 1
    assert 0.018 < np.abs(stiffness).max() <= 0.02 and abs(stiffness.mean()) < 0.002
    terrain = make_suite("ditch", 7, 1).cases[0].terrain
    seen = noise.perceived(terrain, rng)
    solid = terrain.heights > terrain.ditch_height
    assert np.all(seen.heights[~solid] == terrain.heights[~solid])   # ditches stay ditches
    assert 0.005 < np.std(seen.heights[solid] - terrain.heights[solid]) < 0.015 and seen.x0 != terrain.x0


def test_a_profile_is_the_paper_hoppers_in_each_hoppers_units():
    realistic = PROFILES["realistic"]
    assert realistic.for_hopper(ds.SlipParams()) is realistic
    small = ds.SlipParams(mass=3.0, leg_length=0.3, stiffness=981.0, friction=0.6)
    speed = units_of(small).speed
    noise = realistic.for_hopper(small)
    assert noise.apex == pytest.approx((0.003, 0.003, 0.02 * speed)) and speed == pytest.approx(0.7746, abs=1e-4)
    assert (noise.heights, noise.edges, noise.friction) == pytest.approx((0.006, 0.006, 0.0375))
    assert (noise.leg_angle, noise.stiffness, noise.mass) == (0.005, 0.02, 0.02)   # dimensionless: kept
    # the robust particles of that hopper sit at the corners of its noise, with its friction loss
    terrain = ds.Terrain.flat(cell=0.06, x0=-1.8, length=6.6)
    particles = Robustness().particles(ds.ApexState(0.0, 0.33, 0.6), terrain, small)
    assert np.abs(particles.apex_errors).max(axis=0) == pytest.approx((0.006, 0.006, 0.04 * speed))
    assert np.all(particles.worlds.params[:, 4] == pytest.approx(0.6 - 0.0375))
    assert np.abs(particles.worlds.x0 - terrain.x0).max() == pytest.approx(0.012)


@pytest.fixture(scope="module")
def suite():
    return make_suite("ditch", 7, 1, speeds=(2.0, 2.5), heights=(0.9,))


def test_a_noiseless_profile_is_the_protocol(suite, controller):
    planner = planners.make("step", controller=controller)
    case, params = suite.cases[0], ds.SlipParams(friction=suite.friction)
    plain = run_case(planner, controller, case, suite.goal_x, params, ClosedLoopConfig(backend="fast"))
    silent = run_case(planner, controller, case, suite.goal_x, params,
                      ClosedLoopConfig(backend="fast", noise=profile("realistic*0"), seed=5))
    strip = lambda r: [{k: v for k, v in p.items() if k not in ("t_plan_s", "timing")} for p in r["plans"]]
    assert plain["success"] and strip(plain) == strip(silent) and plain["final_x"] == silent["final_x"]


def test_a_noisy_run_repeats_under_its_seed_in_any_order(suite, controller):
    planner = planners.make("step", controller=controller)
    params = ds.SlipParams(friction=suite.friction)
    config = ClosedLoopConfig(executed_per_plan=3, backend="fast", noise=PROFILES["realistic"], seed=3)
    run = lambda case, config: run_case(planner, controller, case, suite.goal_x, params, config)
    first = run(suite.cases[1], config)
    run(suite.cases[0], config)
    again = run(suite.cases[1], config)
    other = run(suite.cases[1], replace(config, seed=4))
    strip = lambda r: [{k: v for k, v in p.items() if k not in ("t_plan_s", "timing")} for p in r["plans"]]
    assert strip(first) == strip(again) and first["final_x"] == again["final_x"]
    assert all("seen_apex" in p and p["seen_apex"] != p["apex"] for p in first["plans"])
    assert other["plans"][0]["seen_apex"] != first["plans"][0]["seen_apex"]


def test_robustness_settings_are_checked_and_relax_in_order():
    rob = Robustness()
    levels = rob.levels()
    assert [(r.depth, r.sigmas) for r in levels] == [(2, 2.0), (1, 2.0), (1, 1.0), (1, 1.0)]
    assert levels[0] is rob and all(r.relaxed == () for r in levels[1:])
    assert [r.max_nodes for r in levels] == [30, 60, 60, 60]
    assert [r.lookahead_angles for r in levels] == [21, 21, 21, 81] and {r.lookahead_depth for r in levels} == {1}
    particles = rob.particles((0.0, 1.0, 2.0), ds.Terrain.flat(), ds.SlipParams())
    assert np.all(particles.states[0] == (0.0, 1.0, 2.0)) and len(particles.states) == 15
    assert len(particles.worlds.x0) == 7 and particles.world[0] == 0 and set(particles.world) == set(range(7))
    for kwargs, message in ((dict(sigmas=-1), "sigmas"), (dict(depth=0), "depth"), (dict(lookahead=1.5), "lookahead"),
                            (dict(max_nodes=0), "max_nodes"), (dict(lookahead_depth=0), "lookahead_depth"),
                            (dict(lookahead_angles=1), "lookahead_angles"),
                            (dict(relaxed=[{"depht": 1}]), "depht"), (dict(relaxed=[{"noise": {}}]), "relaxed"),
                            (dict(landing=float("nan")), "landing")):
        with pytest.raises((ValueError, TypeError), match=message):
            Robustness(**kwargs)
    with pytest.raises(ValueError, match="Robustness.sigmas must be a non-negative number, got .two."):
        planners.make("step", robustness={"sigmas": "two"})


def test_the_robust_plan_survives_noise_that_breaks_the_nominal_one(controller):
    """The README's example case (step suite, case 7): its first 3 hops under realistic noise."""
    suite = make_suite("step", seed=2000, n_terrains=1)
    case, params = suite.cases[7], ds.SlipParams(friction=suite.friction)
    rates = {}
    for label in ("step", "step@robust"):
        plan = planners.make(label, controller=controller).plan(case.apex, case.terrain.perceived(case.apex.x),
                                                                suite.goal_x, params)
        assert plan.success, label
        record = PlanRecord.from_plan(plan, case.apex, case.terrain, suite.goal_x, params)
        rates[label] = success_probability(record, 200, PROFILES["realistic"], seed=0, hops=3,
                                           controller=controller)
    assert rates["step@robust"].interval[0] > 0.5 > rates["step"].interval[1]
    assert "found by robust" in planners.make("step@robust", controller=controller).plan(
        case.apex, case.terrain.perceived(case.apex.x), suite.goal_x, params).message


@pytest.mark.parametrize("family", ["ditch", "step", "mixed"])
def test_the_map_filter_shrinks_height_errors_and_keeps_every_step_and_ditch(family):
    noise, rng = PROFILES["realistic"], np.random.default_rng(1)
    raw, filtered = [], []
    for seed in range(8):
        terrain = ds.TERRAIN_FAMILIES[family](seed)
        assert np.array_equal(terrain.denoised(noise.heights).heights, terrain.heights)   # a true map stays
        seen = noise.perceived(terrain, rng)
        clean = seen.denoised(noise.heights)
        solid = terrain.heights > terrain.ditch_height
        assert np.array_equal(clean.heights[~solid], terrain.heights[~solid]) and clean.x0 == seen.x0
        raw.append(seen.heights[solid] - terrain.heights[solid])
        filtered.append(clean.heights[solid] - terrain.heights[solid])
    raw, filtered = np.concatenate(raw), np.concatenate(filtered)
    assert np.sqrt(np.mean(filtered ** 2)) < 0.75 * np.sqrt(np.mean(raw ** 2))
    assert np.abs(filtered).max() <= np.abs(raw).max()   # no cell takes a neighbouring level's height


def test_the_map_filter_names_its_bad_settings():
    terrain = ds.Terrain.flat()
    assert terrain.denoised(0.0) is terrain and terrain.denoised(0.01, 1) is terrain
    for kwargs, message in ((dict(sigma=float("nan")), "denoised sigma"), (dict(sigma=0.01, window=4), "odd"),
                            (dict(sigma=0.01, window=0), "odd"), (dict(sigma=0.01, window=True), "odd")):
        with pytest.raises(ValueError, match=message):
            terrain.denoised(**kwargs)
    with pytest.raises(ValueError, match="map_filter must be odd"):
        ClosedLoopConfig(map_filter=2)


def test_the_planner_and_the_controller_see_the_filtered_map(suite, controller, monkeypatch):
    import planners.closed_loop as loop
    aimed_on = []

    def rollout(*args, sensed_terrain=None, **kwargs):
        aimed_on.append(sensed_terrain)
        return real_rollout(*args, sensed_terrain=sensed_terrain, **kwargs)

    real_rollout = loop.rollout
    monkeypatch.setattr(loop, "rollout", rollout)

    class Recorder:
        def __init__(self):
            self.planner, self.maps = planners.make("step", controller=controller), []

        def plan(self, apex, terrain, goal_x, params):
            self.maps.append(terrain)
            return self.planner.plan(apex, terrain, goal_x, params)

    noise, params = profile("terrain"), ds.SlipParams(friction=suite.friction)
    maps = {}
    for window in (1, 5):
        recorder = Recorder()
        run_case(recorder, controller, suite.cases[0], suite.goal_x, params,
                 ClosedLoopConfig(backend="fast", noise=noise, seed=2, map_filter=window))
        maps[window] = recorder.maps[0]
        assert aimed_on[0] is recorder.maps[0]   # the controller aims on the map the planner planned on
        aimed_on.clear()
    # the first map is drawn before any plan, so the filtered run saw the unfiltered run's map, filtered
    assert np.array_equal(maps[5].heights, maps[1].denoised(noise.heights, 5).heights)
    assert not np.array_equal(maps[5].heights, maps[1].heights)


def test_robust_presets_carry_their_closed_loop():
    from planners.registry import loop_settings
    assert loop_settings("step@robust") == {"executed_per_plan": 1, "map_filter": 5}
    assert loop_settings("lstm-guided@robust")["map_filter"] == 5 and loop_settings("step") == {}
    ClosedLoopConfig(**loop_settings("step@robust"))
