"""The learned correction of a robot's template: its compiled forward pass agrees with numpy's, a SLIP steps as
before, the weights file is checked, a template names it in a hopper file and records, and training learns a
correction that depends on the hop before."""
import json
from dataclasses import asdict, replace

import numpy as np
import pytest

from drakeslip import SlipParams, Terrain
from drakeslip.apex_correction import (ARRAYS, N_IN, N_OUT, ApexCorrection, correction_of, hop_inputs,
                                       load_correction, output_units, save_correction)
from drakeslip.fast_correction import template_step
from drakeslip.fast_step import N_OUT as STEP_OUT, OK, OUT_CODE, OUT_TD_X, OUT_X, OUT_XDOT, OUT_Z, STANCE_STEPS, step_one
from drakeslip.hopper_file import NamedHopper, load_hopper, save_hopper
from drakeslip.multibody.fit import Hop
from drakeslip.params import RobotTemplate, params_from_record


def random_network(seed: int, hidden: int = 5) -> dict:
    rng = np.random.default_rng(seed)
    shapes = {"w1": (N_IN, hidden), "b1": (hidden,), "w2": (hidden, hidden), "b2": (hidden,),
              "w3": (hidden, N_OUT), "b3": (N_OUT,)}
    arrays = {name: rng.normal(0.0, 0.5, shape) for name, shape in shapes.items()}
    arrays.update(input_low=np.full(N_IN, -3.0), input_high=np.full(N_IN, 3.0), input_mean=rng.normal(0, 0.2, N_IN),
                  input_scale=np.full(N_IN, 0.7), output_scale=np.array([0.02, 0.01, 0.03]),
                  held_out=np.arange(6.0))
    return arrays


@pytest.fixture
def template(tmp_path):
    path = tmp_path / "correction.npz"
    save_correction(path, random_network(3))
    return RobotTemplate(**asdict(SlipParams()), correction=load_correction(path))


def test_compiled_correction_is_numpys(template):
    ground = Terrain.flat(0.0, length=30.0, x0=-5.0).ground()
    rng = np.random.default_rng(0)
    p, plain = template.as_array(), SlipParams().as_array()
    checked = 0
    for _ in range(40):
        apex = (rng.uniform(0, 2), rng.uniform(0.7, 1.0), rng.uniform(0.5, 3.0))
        angle = rng.uniform(0.0, 0.35)
        before_hop = Hop((apex[0] - 0.5, rng.uniform(0.7, 1.0), rng.uniform(0.5, 3.0)), apex[0] - rng.uniform(0.1, 0.4),
                         0.0, apex) if rng.random() < 0.7 else None
        before = np.zeros(4) if before_hop is None else np.array(
            [before_hop.apex[1], before_hop.apex[2], before_hop.foothold - before_hop.apex[0], 1.0])
        out, slip = np.empty(STEP_OUT), np.empty(STEP_OUT)
        template_step(*apex, angle, p, ground, before, out)
        step_one(*apex, angle, plain, ground, np.int64(STANCE_STEPS), slip)
        assert out[OUT_CODE] == slip[OUT_CODE] and out[OUT_TD_X] == slip[OUT_TD_X]
        if slip[OUT_CODE] != OK:
            continue
        hop = Hop(apex, float(slip[OUT_TD_X]), 0.0, (0, 0, 0), before_hop)
        want = correction_of(template.correction.arrays, hop_inputs([hop], 0.5, 9.81))[0] * output_units(0.5, 9.81)
        got = out[[OUT_X, OUT_Z, OUT_XDOT]] - slip[[OUT_X, OUT_Z, OUT_XDOT]]
        assert np.allclose(got, want, rtol=1e-9, atol=1e-12)
        assert np.abs(want).max() > 1e-4   # the correction does something
        checked += 1
    assert checked >= 20


def test_a_slip_steps_as_the_step_map():
    ground = Terrain.flat(0.0, length=30.0, x0=-5.0).ground()
    p = SlipParams().as_array()
    out, slip = np.empty(STEP_OUT), np.empty(STEP_OUT)
    for angle in np.linspace(0.0, 0.4, 9):
        template_step(0.0, 0.9, 1.5, angle, p, ground, np.array([0.4, 1.0, 0.3, 1.0]), out)
        step_one(0.0, 0.9, 1.5, angle, p, ground, np.int64(STANCE_STEPS), slip)
        assert np.array_equal(out, slip, equal_nan=True)


def test_weights_file_is_checked(tmp_path, template):
    path = tmp_path / "c.npz"
    digest = save_correction(path, random_network(1))
    assert load_correction(path).sha256 == digest
    with pytest.raises(ValueError, match="not the file named"):
        ApexCorrection("0" * 64, str(path))
    bad = random_network(1)
    bad["w2"] = bad["w2"][:2]
    save_correction(tmp_path / "bad.npz", bad)
    with pytest.raises(ValueError, match="w2 must be finite of shape"):
        load_correction(tmp_path / "bad.npz")
    partial = {k: v for k, v in random_network(1).items() if k != ARRAYS[0]}
    save_correction(tmp_path / "partial.npz", partial)
    with pytest.raises(ValueError, match="correction weights"):
        load_correction(tmp_path / "partial.npz")


def test_template_in_hopper_file_and_records(tmp_path, template):
    path = tmp_path / "template.json"
    correction_file = tmp_path / "template_correction.npz"
    save_correction(correction_file, template.correction.arrays)
    robot = replace(template, correction=load_correction(correction_file))
    loaded = save_hopper(NamedHopper(robot, "robot"), path).params
    assert isinstance(loaded, RobotTemplate) and loaded == robot
    assert np.array_equal(loaded.as_array(), robot.as_array())
    assert params_from_record(json.loads(json.dumps(asdict(robot)))) == robot
    assert type(params_from_record(asdict(SlipParams()))) is SlipParams
    assert robot.with_friction(0.5).correction == robot.correction
    document = json.loads(path.read_text())
    document["correction"]["sha256"] = "1" * 64
    path.write_text(json.dumps(document))
    with pytest.raises(ValueError, match="template.json: correction weights"):
        load_hopper(path)
    document["correction"] = {"file": "../elsewhere.npz", "sha256": "1" * 64}
    path.write_text(json.dumps(document))
    with pytest.raises(ValueError, match="correction must be"):
        load_hopper(path)


def test_training_learns_what_the_hop_before_does():
    """A robot whose next apex strays from the template by an amount set by its previous foothold: the trained
    correction predicts it on held-out hops, far better than the template does."""
    from drakeslip.multibody.correction_training import CorrectionConfig, corrected_errors, train_correction
    from drakeslip.multibody.fit import predict

    from drakeslip.stepmap import step_batch

    params = SlipParams()
    rng = np.random.default_rng(5)
    flat = Terrain.flat(0.0, length=30.0, x0=-5.0)
    hops = []
    while len(hops) < 300:
        apex = (0.0, rng.uniform(0.75, 0.95), rng.uniform(0.8, 2.5))
        r = step_batch(np.array(apex), np.array([rng.uniform(0.05, 0.3)]), flat, params)
        if not r.ok[0]:
            continue
        previous = Hop((-0.6, rng.uniform(0.75, 0.95), rng.uniform(0.8, 2.5)), -0.6 + rng.uniform(0.1, 0.5), 0.0,
                       apex)
        stray = 0.04 * (previous.foothold - previous.apex[0] - 0.3)
        hops.append(Hop(apex, float(r.touchdown_x[0]), 0.0,
                        (r.next_x[0] + stray, r.next_z[0], r.next_xdot[0] - stray), previous))
    train, test = hops[:200], hops[200:]
    arrays = train_correction(train, test, params, CorrectionConfig(hidden=16, epochs=800, device="cpu"))
    corrected = corrected_errors(test, params, arrays)
    template_error = np.abs(np.array([h.next_apex for h in test]) - predict(test, params))
    assert np.median(corrected[:, 0]) < 0.25 * np.median(template_error[:, 0])
    assert arrays["held_out"][0] == pytest.approx(np.median(corrected[:, 0]))


def test_planner_predicts_with_the_hop_before(template):
    """A robot's template plans with its correction, from the hop that reached the apex when it is told it; a SLIP
    plans the same whatever it is told."""
    import planners
    from drakeslip.terrain import ditch_world

    terrain = ditch_world(150003).perceived(0.0)
    apex = (0.0, 0.85, 1.8)
    before = (-0.9, 0.9, 1.7, -0.55)
    slip = planners.make("step").plan(apex, terrain, 10.0, SlipParams())
    assert np.array_equal(planners.make("step").plan(apex, terrain, 10.0, SlipParams(), before).apexes, slip.apexes)
    told = planners.make("step").plan(apex, terrain, 10.0, template, before)
    untold = planners.make("step").plan(apex, terrain, 10.0, template)
    assert told.success and untold.success and slip.success
    assert not np.array_equal(told.apexes, untold.apexes) and not np.array_equal(untold.apexes, slip.apexes)
    with pytest.raises(ValueError, match="before must be"):
        planners.make("step").plan(apex, terrain, 10.0, template, (0.0, 1.0))
    with pytest.raises(ValueError, match=r"before\[3\]"):
        planners.make("step").plan(apex, terrain, 10.0, template, (0.0, 1.0, 1.0, float("nan")))


def test_planned_hops_leave_out_pumps_and_raibert_hops():
    """The hops a correction learns from are those the robot flew aiming at a plan's foothold with the plan's
    energy; each keeps the hop the robot flew before it, whatever that was."""
    from types import SimpleNamespace

    from verification.robot_hops import hop_from_record, hop_record, planned_hops

    terrain = Terrain.flat(0.1, length=20.0, x0=-2.0)
    apexes = [(0.5, 0.9, 1.5), (1.0, 0.9, 1.5), (1.5, 0.9, 1.5), (2.0, 0.9, 1.5)]
    plans = [{"stamp": 0, "success": True, "footholds": [0.3]},
             {"stamp": 1, "success": True, "footholds": [0.8], "pumped": 0.15},
             {"stamp": 2, "success": True, "footholds": [1.3]},
             {"stamp": 3, "success": False, "footholds": []}]
    log = SimpleNamespace(apexes=apexes, footholds=[0.31, 0.79, 1.29, 1.8], aimed=[(0, 0), (1, 0), (2, 0), (3, 0)])
    case = SimpleNamespace(apex=(0.0, 0.9, 1.5), terrain=terrain)
    hops = planned_hops({"log": log, "plans": plans}, case)
    assert [h.foothold for h in hops] == [0.3, 1.3]            # the pumped hop and the Raibert hop left out
    assert hops[0].previous is None and hops[0].height == pytest.approx(0.1)
    assert hops[1].previous.foothold == 0.79 and hops[1].previous.apex == (0.5, 0.9, 1.5)   # the pumped one
    assert hops[1].apex == (1.0, 0.9, 1.5) and hops[1].next_apex == (1.5, 0.9, 1.5)
    assert [hop_from_record(json.loads(json.dumps(hop_record(h)))) for h in hops] == hops


@pytest.mark.parametrize("args, message", [
    (["--families", "ditch,moon"], "unknown terrain family 'moon'"),
    (["--device", "tpu"], "unknown torch device 'tpu'"),
    (["--template", "no/such.json"], "no/such.json"),
    (["--held-out", "1"], "--held-out"),
])
def test_fit_correction_refuses_bad_input_in_one_line(run_script, args, message):
    code, stdout, err = run_script("fit_correction", *args)
    assert code == 2 and message in err and len(err.splitlines()) == 1 and not stdout


def test_evaluate_takes_a_template_for_the_robot_only(run_script):
    code, stdout, err = run_script("evaluate", "--suite", "suites/ditch.json", "--out", "out/x.json",
                                   "--template", "drakeslip/multibody/template.json")
    assert code == 2 and "--template needs --backend multibody" in err and len(err.splitlines()) == 1


@pytest.mark.slow
def test_fit_correction_regenerates_a_template_that_loads(run_script, tmp_path):
    """The regeneration command end to end on a few cases: it runs them on the robot, keeps their hops, trains,
    and writes a corrected template whose weights load against their digest; run again, it reuses the hops."""
    out, hops = tmp_path / "corrected.json", tmp_path / "hops.json"
    args = ["--families", "ditch", "--cases", "4", "--held-out", "2", "--epochs", "30", "--device", "cpu",
            "--out", out, "--hops", hops]
    code, stdout, err = run_script("fit_correction", *args)
    assert code == 0, err
    assert "0 cases from" in stdout and "template+correction" in stdout
    template = load_hopper(out).params
    assert isinstance(template, RobotTemplate) and (tmp_path / "template_correction.npz").is_file()
    assert template.slip == load_hopper("drakeslip/multibody/template.json").params
    code, stdout, _ = run_script("fit_correction", *args)
    assert code == 0 and "4 cases from" in stdout and "0 to run" in stdout
    assert load_hopper(out).params == template   # the same hops, the same weights


@pytest.mark.slow
def test_fit_correction_trains_another_hoppers_robots_correction(run_script, tmp_path):
    """--hopper: the hopper's robot runs its suites, and the corrected template is the one that robot's planners
    plan for (``template_for``), accepted for that hopper and refused for the paper's."""
    from drakeslip.multibody.fit import template_for

    hopper = tmp_path / "big.json"
    hopper.write_text(json.dumps({"format": "drakeslip-hopper/1", "name": "big", "mass": 20.0, "leg_length": 0.8,
                                  "stiffness": 5723.0, "gravity": 9.81, "friction": 0.8, "min_leg_length": 0.48}))
    out = tmp_path / "corrected.json"
    code, _, err = run_script("fit_correction", "--hopper", hopper, "--families", "ditch", "--cases", "4",
                              "--held-out", "2", "--epochs", "30", "--device", "cpu", "--out", out,
                              "--hops", tmp_path / "hops.json")
    assert code == 0, err
    template, big = load_hopper(out).params, load_hopper(hopper).params
    assert template.slip == template_for(big, load_hopper("drakeslip/multibody/template.json").params)
    assert template_for(big, template) == template
    with pytest.raises(ValueError, match="trained on another hopper's robot"):
        template_for(load_hopper("drakeslip/hoppers/paper.json").params, template)
