"""Plan files (planners.formats.plan) and plan checking on Drake (verification.plan_check): a certificate with
positive margins for a plan that works, the right counterexample for plans known to fail."""
import json
from pathlib import Path

import numpy as np
import pytest

import drakeslip as ds
import planners
from drakeslip import FailureMode
from drakeslip.controller import StepLengthController
from planners.base import FootstepSequence, Plan
from planners.formats.plan import PlanRecord, load_plan, save_plan
from planners.formats.suite import make_suite, save_suite
from verification.plan_check import Certificate, Counterexample, check_plan

ROOT = Path(__file__).resolve().parents[1]
PARAMS = ds.SlipParams()
START = ds.ApexState(0.0, 0.8, 1.5)


@pytest.fixture(scope="module")
def controller():
    return StepLengthController.load_default()


@pytest.fixture(scope="module")
def step_case():
    """Case 7 of the committed step suite (step-2000-v2.5-z1), crossed by the Step-space planner in 4 hops."""
    suite = make_suite("step", seed=2000, n_terrains=1)
    return suite, suite.cases[7]


@pytest.fixture(scope="module")
def step_record(step_case, controller):
    suite, case = step_case
    params = ds.SlipParams(friction=suite.friction)
    plan = planners.make("step", controller=controller).plan(case.apex, case.terrain.perceived(case.apex.x),
                                                             suite.goal_x, params)
    assert plan.success
    return PlanRecord.from_plan(plan, case.apex, case.terrain, suite.goal_x, params)


def hand_plan(footholds, angles, terrain) -> PlanRecord:
    n = len(footholds)
    return PlanRecord("hand", START, terrain, PARAMS, 10.0, 5.0, np.array(footholds, dtype=float),
                      np.array(angles, dtype=float), np.full((n, 3), np.nan))


def ditch_plan(controller) -> PlanRecord:
    """Hop 1's leg angle would land the foot at x = 1.45 on flat ground, but there is a ditch at 1.3-1.6."""
    heights = ds.Terrain.flat().heights.copy()
    heights[43:46] = ds.terrain.DITCH_HEIGHT
    terrain = ds.Terrain(heights)
    first = ds.step(START, controller.leg_angle(START, 0.48, terrain), terrain)
    return hand_plan([0.48, 1.45], [controller.leg_angle(START, 0.48, terrain),
                                    controller.leg_angle(first.next_apex, 1.45, ds.Terrain.flat())], terrain)


def test_step_plan_is_certified_with_positive_margins(step_record):
    result = check_plan(step_record)
    assert isinstance(result, Certificate) and result.ok, result.format()
    assert result.mode == "angles" and len(result.footholds) == len(step_record.footholds) == 4
    for name, margin in result.margins().items():
        assert margin.value > 0, (name, margin)
    assert 0 < result.max_compression < result.stroke_length
    assert result.deviation < 1e-5
    assert result.apexes[-1][0] > step_record.footholds[-1]
    assert json.loads(json.dumps(result.to_dict(), allow_nan=False))["verdict"] == "certified"


def test_auto_mode_executes_footholds_when_angles_are_missing(step_record):
    """An lstm plan has only its first leg angle: "auto" aims at the footholds through the controller."""
    angles = np.full(step_record.leg_angles.shape, np.nan)
    angles[0] = step_record.leg_angles[0]
    record = PlanRecord(**{**step_record.__dict__, "leg_angles": angles})
    result = check_plan(record)
    assert isinstance(result, Certificate) and result.mode == "footholds"
    assert result.deviation < 1e-6
    with pytest.raises(ValueError, match=r"leg_angles\[1\] = nan"):
        check_plan(record, mode="angles")


def test_foothold_in_a_ditch_is_a_foot_collision_at_hop_1(controller):
    result = check_plan(ditch_plan(controller))
    assert isinstance(result, Counterexample) and not result.ok, result
    assert result.failure is FailureMode.FOOT_COLLISION and result.hop == 1
    # The foot fell into the ditch and struck its far wall.
    assert result.foot[0] == pytest.approx(1.6, abs=1e-6) and -1.0 < result.foot[1] < 0
    assert result.hybrid["mode"] == "FAILED" and result.hybrid["failure"] == "FOOT_COLLISION"
    assert [t["hop"] for t in result.trace] == [0, 1]
    assert result.trace[0]["foothold"] == pytest.approx(0.48, abs=1e-6) and result.trace[1]["foothold"] is None
    assert result.trace[1]["apex"][0] == pytest.approx(0.987, abs=1e-3)   # the apex reached after hop 0
    assert result.time > 0 and result.x > 1.0
    assert "FOOT_COLLISION at hop 1" in result.format()


def test_leg_angle_outside_the_friction_cone_slips_at_hop_1():
    """atan(0.8) = 0.675 rad: a 0.75 rad leg touches down outside the cone."""
    result = check_plan(hand_plan([0.476, 1.82], [0.2, 0.75], ds.Terrain.flat()))
    assert isinstance(result, Counterexample)
    assert result.failure is FailureMode.SLIP and result.hop == 1 and result.mode == "angles"
    assert result.trace[1]["leg_angle"] == 0.75
    assert result.foot[0] == pytest.approx(1.82, abs=1e-3)


def test_plan_file_round_trip_keeps_missing_predictions(tmp_path, step_record):
    path = tmp_path / "plan.json"
    plan = Plan("lstm", True, 6.0, sequences=[FootstepSequence(
        np.array([0.5, 1.0]), np.array([0.2, np.nan]), np.array([[1.0, 0.8, 1.5], [np.nan] * 3]))])
    saved = save_plan(path, plan, START, {"family": "ditch", "seed": 3}, 10.0, PARAMS)
    text = path.read_text()
    assert "NaN" not in text and json.loads(text)["leg_angles"] == [0.2, None]
    loaded = load_plan(path)
    assert loaded.planner == "lstm" and loaded.apex == START and loaded.params == PARAMS
    np.testing.assert_array_equal(loaded.terrain.heights, ds.ditch_world(3).heights)
    for field in ("footholds", "leg_angles", "apexes"):
        np.testing.assert_array_equal(getattr(loaded, field), getattr(saved, field))   # NaN == NaN here
    step_record.save(path)
    again = load_plan(path)
    assert again.to_dict() == step_record.to_dict()


@pytest.mark.parametrize("edit, field", [
    (lambda d: d.update(format="drakeslip-plan/0"), "format"),
    (lambda d: d.pop("goal_x"), "'goal_x'"),
    (lambda d: d["footholds"].__setitem__(2, None), r"footholds\[2\]"),
    (lambda d: d["leg_angles"].pop(), "leg_angles must be a list of 4"),
    (lambda d: d["apexes"].__setitem__(1, [1.0, 2.0]), r"apexes\[1\]"),
    (lambda d: d["apex"].update(z=-5.0), r"apex\.z"),
    (lambda d: d["params"].update(stiffness=-1), "params.*stiffness"),
    (lambda d: d["terrain"]["heights"].__setitem__(7, "deep"), r"terrain\.heights\[7\]"),
])
def test_malformed_plan_file_names_the_file_and_field(tmp_path, step_record, edit, field):
    doc = step_record.to_dict()
    edit(doc)
    path = tmp_path / "bad-plan.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match=f"bad-plan.json.*{field}"):
        load_plan(path)


def test_cli_make_plan_then_verify_exit_codes(tmp_path, controller, run_script):
    suite = tmp_path / "suite.json"
    save_suite(make_suite("step", seed=2000, n_terrains=1), suite)
    plan = tmp_path / "plan.json"
    code, _, err = run_script("make_plan", "--suite", suite, "--case", "step-2000-v2.5-z1", "--planner", "step",
                              "--out", plan)
    assert code == 0, err
    assert load_plan(plan).planner == "step"
    out = tmp_path / "check.json"
    ditch_plan(controller).save(tmp_path / "ditch.json")
    code, stdout, _ = run_script("verify_plan", "--plan", tmp_path / "ditch.json", "--out", out)
    assert code == 1 and "COUNTEREXAMPLE" in stdout
    assert json.loads(out.read_text())["failure"] == "FOOT_COLLISION"
    (tmp_path / "broken.json").write_text("{")
    code, _, err = run_script("verify_plan", "--plan", tmp_path / "broken.json")
    assert code == 2 and "broken.json is not valid JSON" in err and len(err.splitlines()) == 1
    # a terrain file that does not hold the plan's course would certify it on the flat ground past its ends
    (tmp_path / "short.csv").write_text("0,0\n0.5,0\n")
    code, _, err = run_script("verify_plan", "--plan", plan, "--terrain", tmp_path / "short.csv")
    assert code == 2 and len(err.splitlines()) == 1, err
    assert "short.csv covers x in [0, " in err and "give a terrain that covers it" in err


def test_every_registered_planner_is_known_after_import_planners():
    # a fresh interpreter: trajopt must be registered by `import planners` alone, not by an earlier test's import
    import subprocess
    import sys

    out = subprocess.run([sys.executable, "-c", "import planners; print(','.join(planners.available()))"],
                         capture_output=True, text=True, check=True, cwd=ROOT).stdout.strip()
    assert out.split(",") == ["angle", "heuristic", "lstm", "lstm-guided", "step", "trajopt"]


def test_cli_make_plan_with_trajopt_options_is_certified(tmp_path, capsys, example):
    suite = tmp_path / "suite.json"
    save_suite(make_suite("step", seed=2000, n_terrains=1), suite)
    make = example("make_plan").main
    base = ["--suite", str(suite), "--case", "step-2000-v2.5-z1", "--planner", "trajopt"]
    for bad, message in (('{"bogus": 1}', "unexpected keyword argument 'bogus'"), ("[1]", "must be a JSON object"),
                         ("{seed", "not valid JSON"), ('{"seed": "mode"}', "unknown seed 'mode'")):
        with pytest.raises(SystemExit):
            make(base + ["--options", bad, "--out", str(tmp_path / "bad.json")])
        assert message in capsys.readouterr().err
    plan = tmp_path / "trajopt.json"
    assert make(base + ["--options", '{"seed": "lstm-guided"}', "--out", str(plan)]) == 0
    record = load_plan(plan)
    assert record.planner == "trajopt" and np.all(np.isfinite(record.leg_angles))
    assert example("verify_plan").main(["--plan", str(plan)]) == 0
    assert "CERTIFIED" in capsys.readouterr().out
