"""Monte Carlo robustness of a plan (verification.robustness): deterministic under a seed, certain without
noise for a certified plan, falling with large noise, and confirmed on Drake for the same draws."""
import numpy as np
import pytest

import drakeslip as ds
import planners
from drakeslip.controller import StepLengthController
from planners.formats.plan import PlanRecord
from planners.formats.suite import make_suite
from drakeslip.noise import NoiseProfile, profile
from verification.robustness import confirm_on_drake, draw_robots, success_probability, wilson_interval

NOISY = dict(noise=NoiseProfile(apex=(0.01, 0.01, 0.05), leg_angle=0.02))
CLEAN = dict(noise=profile("none"))


@pytest.fixture(scope="module")
def controller():
    return StepLengthController.load_default()


@pytest.fixture(scope="module")
def record(controller):
    """The Step-space plan for step-2000-v2.5-z1 (4 hops), certified in tests/test_plan_check.py."""
    suite = make_suite("step", seed=2000, n_terrains=1)
    case = suite.cases[7]
    params = ds.SlipParams(friction=suite.friction)
    plan = planners.make("step", controller=controller).plan(case.apex, case.terrain.perceived(case.apex.x),
                                                             suite.goal_x, params)
    return PlanRecord.from_plan(plan, case.apex, case.terrain, suite.goal_x, params)


def test_wilson_interval():
    assert wilson_interval(0, 10) == pytest.approx((0.0, 0.27753), abs=1e-5)
    assert wilson_interval(10, 10) == pytest.approx((0.72247, 1.0), abs=1e-5)
    assert wilson_interval(5, 10) == pytest.approx((0.23659, 0.76341), abs=1e-5)
    with pytest.raises(ValueError, match="n=0"):
        wilson_interval(0, 0)


def test_deterministic_under_a_seed(record, controller):
    a = success_probability(record, 200, seed=3, controller=controller, **NOISY)
    b = success_probability(record, 200, seed=3, controller=controller, **NOISY)
    c = success_probability(record, 200, seed=4, controller=controller, **NOISY)
    starts = lambda r: np.array([d.start for d in r.draws])
    np.testing.assert_array_equal(starts(a), starts(b))
    np.testing.assert_array_equal(a.failures, b.failures)
    np.testing.assert_array_equal(a.failed_hops, b.failed_hops)
    assert not np.array_equal(starts(a), starts(c))


def test_certain_without_noise_and_falls_with_large_noise(record, controller):
    clean = success_probability(record, 500, seed=0, controller=controller, **CLEAN)
    assert clean.rate == 1.0 and clean.interval[0] > 0.99 and clean.failure_counts() == {}
    noisy = success_probability(record, 500, seed=0, controller=controller, **NOISY)
    assert noisy.rate < 0.5 and noisy.interval[1] < 0.5
    assert sum(noisy.failure_counts().values()) == noisy.n - noisy.successes
    assert np.all((noisy.failed_hops >= 0) == (noisy.failures != 0))
    assert "Wilson interval" in noisy.format()


def test_drake_confirms_the_same_draws(record, controller):
    clean = success_probability(record, 10, seed=0, controller=controller, **CLEAN)
    confirmation = confirm_on_drake(clean, 1, controller=controller)
    assert confirmation.n == 1 and confirmation.agreement == 1.0 and confirmation.drake.tolist() == [0]
    noisy = success_probability(record, 10, seed=1, controller=controller, **NOISY)
    confirmation = confirm_on_drake(noisy, 2, controller=controller)
    np.testing.assert_array_equal(confirmation.fast, noisy.failures[:2])
    assert confirmation.agreement == 1 - len(confirmation.disagreements) / 2


@pytest.mark.parametrize("call, message", [
    (lambda r: success_probability(r, 0, **CLEAN), "n must be"),
    (lambda r: success_probability(r, 10, NoiseProfile(apex=(0.1, -1, 0))), "must not be negative"),
    (lambda r: success_probability(r, 10, NoiseProfile(leg_angle=float("nan"))), "leg_angle"),
    (lambda r: success_probability(r, 10, backend="gpu", **CLEAN), "backend"),
    (lambda r: success_probability(r, 10, **CLEAN, hops=9), r"hops must be an integer in \[1, 4\], got 9"),
    (lambda r: success_probability(r, 10, **CLEAN, map_filter=4), "map_filter must be odd"),
    (lambda r: confirm_on_drake(success_probability(r, 5, **CLEAN), 6), r"n_small must be an integer in \[1, 5\]"),
])
def test_bad_arguments_are_named(record, call, message):
    with pytest.raises(ValueError, match=message):
        call(record)


def test_cli(tmp_path, record, run_script):
    record.save(tmp_path / "plan.json")
    code, out, _ = run_script("robustness", "--plan", tmp_path / "plan.json", "--samples", "50", "--seed", "1",
                              "--noise", "none")
    assert code == 0 and "success rate 1.0000 (50/50)" in out
    (tmp_path / "bad.json").write_text("[]")
    code, _, err = run_script("robustness", "--plan", tmp_path / "bad.json")
    assert code == 2 and "must be an object, got list" in err and len(err.splitlines()) == 1
    code, _, err = run_script("robustness", "--plan", tmp_path / "plan.json", "--noise", "realistic*nan")
    assert code == 2 and "--noise" in err and len(err.splitlines()) == 1


def test_each_robot_filters_the_map_it_senses(record):
    """With ``map_filter`` every draw is the same robot, aiming on its sensed map filtered; the result says so."""
    noise = profile("terrain")
    raw = draw_robots(record, 3, noise, seed=2, hops=2)
    filtered = draw_robots(record, 3, noise, seed=2, hops=2, map_filter=5)
    for a, b in zip(raw, filtered):
        assert np.array_equal(b.sensed.heights, a.sensed.denoised(noise.heights, 5).heights)
        assert np.array_equal(a.apex_errors, b.apex_errors) and a.params == b.params
    assert any(not np.array_equal(a.sensed.heights, b.sensed.heights) for a, b in zip(raw, filtered))
    assert success_probability(record, 4, noise, map_filter=5).to_dict()["map_filter"] == 5
