"""The planar robot of any hopper: the paper's robot in the hopper's units (``RobotParams.for_hopper``), its
controller's gains and thresholds and its monitor's in the same units, and the template its planners plan for
(``drakeslip.multibody.fit.template_for``)."""
import dataclasses

import numpy as np
import pytest

import drakeslip as ds
from drakeslip.multibody import gains as ctl
from drakeslip.multibody.execute import hop_at_speed
from drakeslip.multibody.fit import template_for
from drakeslip.multibody.robot import SCALING, RobotParams, hopper_sdf, model_geometry
from drakeslip.units import units_of

# Froude-similar to the paper's hopper (k L0 / (m g) and friction the same): twice the mass, twice the leg
SIMILAR = ds.SlipParams(mass=14.0, leg_length=1.0, stiffness=3200.0, min_leg_length=0.6)
OTHER = ds.SlipParams(mass=4.0, leg_length=0.4, stiffness=3500.0, min_leg_length=0.25, friction=0.7)


def test_the_paper_hoppers_robot_is_the_default_robot_to_the_bit():
    from drakeslip.multibody.diagram import build_diagram

    assert RobotParams.for_hopper(ds.SlipParams()) == RobotParams()
    hd = build_diagram(ds.Terrain.flat(), RobotParams.for_hopper(ds.SlipParams()))
    c = hd.controller.scaled
    assert (c.flight_gains, c.stance_gains, c.leg_gains) == (ctl.FLIGHT_GAINS, ctl.STANCE_GAINS, ctl.LEG_GAINS)
    assert (c.retract, c.clearance, c.touchdown_rate, c.min_stance, c.speed_gain) == (
        ctl.RETRACT, ctl.CLEARANCE, ctl.TOUCHDOWN_RATE, ctl.MIN_STANCE, ctl.SPEED_GAIN)


@pytest.mark.parametrize("slip", [SIMILAR, OTHER], ids=["similar", "other"])
def test_another_hoppers_robot_is_the_paper_robot_in_its_units(slip):
    from drakeslip.multibody.diagram import build_diagram
    from drakeslip.multibody.failures import SLIP_DISTANCE, TRIP_GRACE, HopMonitor

    u, paper = units_of(slip), RobotParams()
    robot = RobotParams.for_hopper(slip, leg_damping=3.0)
    for name, (m, length, t) in SCALING.items():
        wanted = 3.0 if name == "leg_damping" else getattr(paper, name) * u.mass ** m * u.length ** length * u.time ** t
        assert getattr(robot, name) == pytest.approx(wanted, rel=1e-12), name
    assert robot.slip == slip and robot.hip_torque_limit != paper.hip_torque_limit
    geometry, base = model_geometry(robot), model_geometry(paper)
    assert geometry.leg_com == pytest.approx(base.leg_com * u.length, rel=1e-12)
    assert geometry.leg_inertia == pytest.approx(base.leg_inertia * u.mass * u.length ** 2, rel=1e-12)
    assert geometry.body_half == pytest.approx(tuple(h * u.length for h in base.body_half), rel=1e-12)
    assert f"<mass>{slip.mass!r}</mass>" in hopper_sdf(robot)
    hd = build_diagram(ds.Terrain.flat(), robot)
    c = hd.controller.scaled
    assert c.flight_gains[0] == pytest.approx(ctl.FLIGHT_GAINS[0] * u.mass * u.length ** 2 / u.time ** 2)
    assert c.leg_gains[0] == pytest.approx(ctl.LEG_GAINS[0] * u.mass / u.time ** 2)
    assert (c.retract, c.min_stance) == pytest.approx((ctl.RETRACT * u.length, ctl.MIN_STANCE * u.time))
    monitor = HopMonitor(hd, ds.Terrain.flat(), hd.diagram.CreateDefaultContext(), None)
    assert (monitor.slip_distance, monitor.trip_grace) == pytest.approx((SLIP_DISTANCE * u.length,
                                                                          TRIP_GRACE * u.time))
    assert robot.face_keep_out == pytest.approx(paper.face_keep_out * u.length)


def test_a_similar_hoppers_robot_hops_as_the_paper_robot_in_its_units():
    """Hopping at 1.5 speed units on flat ground, the apexes of the robot of a hopper twice the paper's size, in
    leg lengths and speed units, are the paper robot's to a few thousandths (Drake's contact is not exactly
    scale-free): every value of the robot and its controller scales."""
    apexes = []
    for slip in (ds.SlipParams(), SIMILAR):
        u = units_of(slip)
        log = hop_at_speed(1.5 * u.speed, 6, RobotParams.for_hopper(slip), apex_height=0.62 * u.length)
        assert log.failure is None and len(log.apexes) == 6
        apexes.append(np.array([(a.x / u.length, a.z / u.length, a.xdot / u.speed) for a in log.apexes]))
    error = np.abs(apexes[0] - apexes[1]).max(axis=0)
    assert error[0] < 0.01 and error[1] < 0.001 and error[2] < 0.005, error


def test_the_template_for_a_hoppers_robot_takes_the_fit_as_factors():
    from drakeslip.hopper_file import load_hopper
    from drakeslip.multibody.fit import TEMPLATE_FILE

    fitted = load_hopper(TEMPLATE_FILE).params
    assert template_for(ds.SlipParams(friction=0.6), fitted) == fitted.with_friction(0.6)
    similar = template_for(SIMILAR, fitted)
    assert similar.leg_length == pytest.approx(fitted.leg_length * 2) and similar.mass == 14.0
    assert similar.stiffness == pytest.approx(fitted.stiffness)
    other = template_for(OTHER, fitted)
    assert (other.leg_length / OTHER.leg_length, other.stiffness / OTHER.stiffness) == pytest.approx(
        (fitted.leg_length / 0.5, fitted.stiffness / 3200.0))
    assert (other.friction, other.min_leg_length) == (0.7, 0.25)
    corrected = load_hopper(TEMPLATE_FILE.with_name("template_corrected.json")).params
    assert type(template_for(ds.SlipParams(), corrected)) is type(corrected)
    with pytest.raises(ValueError, match="learned correction was trained on another hopper's robot"):
        template_for(OTHER, corrected)
    own = dataclasses.replace(corrected, **{k: getattr(other, k) for k in ("mass", "leg_length", "stiffness",
                                                                           "min_leg_length")})
    assert type(template_for(OTHER, own)) is type(corrected)   # a correction trained on OTHER's robot is its own


def test_the_paper_hoppers_run_records_the_robot_and_template_it_did_before():
    """Resolving the robot of the suite's hopper changes nothing a paper-hopper run records (its cache key)."""
    from drakeslip.multibody.fit import fitted_template
    from planners.closed_loop import ClosedLoopConfig, robot_config

    config = ClosedLoopConfig(backend="multibody", template=fitted_template())
    assert robot_config(config, ds.SlipParams()).to_dict() == config.to_dict()
    assert robot_config(ClosedLoopConfig(), OTHER) == ClosedLoopConfig()   # not the robot: unchanged


def test_another_hoppers_acceptance_runs_its_own_robot_and_records_it():
    """``hopper_acceptance`` on the multibody backend: the heaviest corner hopper's robot runs, planned for with its
    template, and the results record both."""
    from dataclasses import asdict

    from drakeslip.multibody.fit import fitted_template
    from verification.hopper_acceptance import evaluate_hopper, random_hoppers

    h = random_hoppers(35, 0)[1]
    results = evaluate_hopper(h, "ditch", 35000, ["step@robust"], every=75, backend="multibody")
    run = results["planners"]["step@robust"]
    assert run["config"]["robot"]["params"] == RobotParams.for_hopper(h.params).to_dict()
    assert run["config"]["template"] == asdict(template_for(h.params, fitted_template()))
    assert len(run["cases"]) == 2 and all(c["what"] for c in run["cases"])


@pytest.mark.parametrize("maps", [False, True], ids=["profile", "map"])
def test_evaluate_gives_the_robot_the_template_it_is_told(example, tmp_path, maps):
    """``evaluate.py --backend multibody --template``: on a profile suite the planar fit made the hopper's robot's, on
    a map suite the spatial fit (each checked before any case runs)."""
    from drakeslip.hopper_file import load_hopper
    from drakeslip.spatial.multibody.fit import FIT_FILE, fitted_template as spatial_fit
    from planners.formats.map_suite import make_map_suite, save_map_suite

    module = example("evaluate")
    if maps:
        suite, template = tmp_path / "gaps.json", str(FIT_FILE)
        save_map_suite(make_map_suite("gaps", 3, n_maps=1, speeds=(1.0,), heights=(0.8,)), suite)
    else:
        suite, template = "suites/ditch.json", "drakeslip/multibody/template.json"
    ap = module.arguments()
    args = ap.parse_args(["--suite", str(suite), "--backend", "multibody", "--template", template, "--planners",
                          "step@robust", "--out", str(tmp_path / "r.json")])
    labels, options = module.checked_labels(ap, args)
    on_maps = module.on_maps(ap, args)
    configs = module.loop_configs(ap, args, labels, on_maps)
    _, _, configs = module.checked_suite(ap, args, labels, options, configs, on_maps)
    wanted = spatial_fit(ds.SlipParams()) if maps else load_hopper(template).params
    assert on_maps == maps and configs["step@robust"].template == wanted


def test_plan_and_hop_draws_the_hoppers_own_robot(run_script, tmp_path, monkeypatch):
    """``plan_and_hop.py --hopper H --backend multibody``: the figure and the replay draw H's robot (its parts'
    sizes), not the paper's."""
    import json

    from drakeslip.multibody import replay

    drawn = []
    for name in ("plot_robot_run", "write_robot_replay"):
        real = getattr(replay, name)
        def recording(*args, _real=real, **kwargs):   # the robot is plot_robot_run's third argument, a keyword here
            drawn.append(kwargs.get("robot", args[2] if len(args) > 2 else None))
            return _real(*args, **kwargs)
        monkeypatch.setattr(replay, name, recording)
    hopper = tmp_path / "big.json"
    hopper.write_text(json.dumps({"format": "drakeslip-hopper/1", "name": "big", "mass": 14.0, "leg_length": 1.0,
                                  "stiffness": 3200.0, "min_leg_length": 0.6}))
    code, _, err = run_script("plan_and_hop", "--hopper", hopper, "--backend", "multibody", "--terrain", "ditch",
                              "--seed", "3", "--out", tmp_path / "r.png", "--html", tmp_path / "r.html")
    assert code in (0, 1), err
    assert drawn == [RobotParams.for_hopper(SIMILAR)] * 2
    paper_half = model_geometry(RobotParams()).body_half
    assert model_geometry(drawn[0]).body_half == pytest.approx(tuple(2 * h for h in paper_half))
