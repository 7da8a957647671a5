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
                          ("realistic*-1", "finite number >= 0"), ("realistic*inf", "finite number >= 0")):
        with pytest.raises(ValueError, match=message):
            profile(spec)
    for kwargs, message in ((dict(leg_angle=-0.1), "must not be negative"), (dict(apex=(0, 0)), "apex must be"),
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


@pytest.fixture(scope="module")
def suite():
    return make_suite("ditch", 7, 1, speeds=(2.0, 2.5), heights=(0.9,))


def test_a_noiseless_profile_is_the_protocol(suite, controller):
    planner = planners.make("step", controller=controller)
    case, params = suite.cases[0], ds.SlipParams(friction=suite.friction)
    plain = run_case(planner, controller, case, suite.goal_x, params, ClosedLoopConfig(backend="fast"))
    silent = run_case(planner, controller, case, suite.goal_x, params,
                      ClosedLoopConfig(backend="fast", noise=profile("realistic*0"), seed=5))
    strip = lambda r: [{k: v for k, v in p.items() if k != "t_plan_s"} for p in r["plans"]]
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
    strip = lambda r: [{k: v for k, v in p.items() if k != "t_plan_s"} for p in r["plans"]]
    assert strip(first) == strip(again) and first["final_x"] == again["final_x"]
    assert all("seen_apex" in p and p["seen_apex"] != p["apex"] for p in first["plans"])
    assert other["plans"][0]["seen_apex"] != first["plans"][0]["seen_apex"]


def test_robustness_settings_are_checked_and_relax_in_order():
    rob = Robustness()
    levels = rob.levels()
    assert [(r.depth, r.sigmas) for r in levels] == [(2, 2.0), (1, 2.0), (1, 1.0)]
    assert levels[0] is rob and all(r.relaxed == () for r in levels[1:])
    assert [r.max_nodes for r in levels] == [30, 60, 60]
    particles = rob.particles((0.0, 1.0, 2.0), ds.Terrain.flat(), ds.SlipParams())
    assert np.all(particles.states[0] == (0.0, 1.0, 2.0)) and len(particles.states) == 15
    assert len(particles.worlds.x0) == 7 and particles.world[0] == 0 and set(particles.world) == set(range(7))
    for kwargs, message in ((dict(sigmas=-1), "sigmas"), (dict(depth=0), "depth"), (dict(lookahead=1.5), "lookahead"),
                            (dict(max_nodes=0), "max_nodes"),
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
