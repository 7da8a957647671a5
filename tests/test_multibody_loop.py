"""The robot's closed loop: the planner system in a diagram built by hand and in the loop's Diagram (its face
keep-out, its noise and records in the Context), the robot pumping energy the template has not, the controller built
for the model under a noise profile's model mismatch, and the loop's config reaching the robot."""
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

import drakeslip as ds
from drakeslip.multibody.robot import RobotParams
from test_multibody import ROOT, ditches_case, example_module


def test_the_planner_system_in_a_user_built_diagram_plans_at_every_apex():
    records, x, seconds, apexes = example_module().run("step@robust", 2.0, seconds=2.5)
    assert apexes >= 3 and len(records) == apexes + 1   # the start is an apex too
    assert all(record["success"] for record in records)
    xs = [record["apex"][0] for record in records]
    assert xs == sorted(xs)


def test_the_robots_planner_places_no_foothold_just_before_a_steps_face():
    """The foot ball rolls and is dragged at liftoff: a foothold just before a rise lets it catch the face."""
    from dataclasses import replace

    from planners.drake_system import build_closed_loop
    from planners.replanning import Replanner

    terrain, robot = ds.step_world(3), RobotParams()
    h = terrain.heights
    rise = np.flatnonzero((h[1:] - h[:-1] > 0.02) & (h[:-1] > terrain.ditch_height)) + 1
    faces = terrain.x0 + terrain.cell * rise
    hd = build_closed_loop(Replanner("step@robust", terrain, 6.0, ds.SlipParams()), robot)
    replanner = hd.planner.replanner
    assert replanner.face_keep_out == pytest.approx(robot.foot_radius + 0.05)
    footholds = hd.planner.start(hd.planner.CreateDefaultContext(), ds.ApexState(0.0, 0.65, 1.5)).footholds

    def footholds_before_faces(footholds) -> list:
        assert len(footholds) >= 10
        return [f for f in footholds if np.any((faces > f) & (faces - f < robot.face_keep_out))]

    assert footholds_before_faces(footholds) == []
    as_sensed = replace(replanner, face_keep_out=0.0).plan(ds.ApexState(0.0, 0.65, 1.5), None, None)
    assert footholds_before_faces(as_sensed.plan.footholds)   # planning on the map as sensed lands next to a face
    with pytest.raises(ValueError, match="face_keep_out"):
        Replanner("step@robust", terrain, 6.0, ds.SlipParams(), face_keep_out=float("nan"))


def test_the_planner_system_keeps_its_noise_and_records_in_the_context():
    """One closed-loop Diagram simulated twice, each from a fresh Context, under noise: the same plans."""
    from drakeslip.noise import profile
    from planners.drake_system import build_closed_loop, simulate_closed_loop
    from planners.replanning import Replanner

    case = ditches_case()
    replanner = Replanner("step@robust", case.terrain, 2.5, ds.SlipParams(), profile("realistic"))
    hd = build_closed_loop(replanner, seed=5)
    runs = [simulate_closed_loop(hd, case, 2.5, max_hops=6) for _ in range(2)]
    plans = [[{k: v for k, v in p.items() if k not in ("t_plan_s", "timing")} for p in r["plans"]] for r in runs]
    assert len(plans[0]) >= 3 and all("seen_apex" in p for p in plans[0])
    assert plans[0] == plans[1] and runs[0]["final_x"] == runs[1]["final_x"]
    assert hd.planner.records(hd.planner.CreateDefaultContext()) == ()


def test_the_pump_asks_for_energy_where_the_foot_cannot_swing_through_under_the_apex():
    from drakeslip.multibody.gains import STANCE_TIME
    from drakeslip.multibody.pump import EnergyPump

    pump, flat = EnergyPump(0.5, 0.15, 0.02, STANCE_TIME), ds.Terrain.flat()
    assert pump.needed([(0.0, 0.52, 0.5)], flat)            # a slow apex a leg length up: the foot scrapes
    assert not pump.needed([(0.0, 0.6, 0.5)], flat)
    assert not pump.needed([(0.0, 0.5, 3.3)], flat)          # a fast skim: the leg waits far forward
    step = ds.Terrain(np.where(np.arange(200) * 0.05 - 3.0 >= 0.05, 0.1, 0.0), cell=0.05, x0=-3.0)
    assert pump.needed([(0.0, 0.6, 1.0)], step)              # the ground ahead under the foot is what counts
    assert not pump.needed([(0.0, 0.6, 1.0)], flat)
    apex = ds.ApexState(-1.0, 0.8, 1.0)                      # a hop in place covers about 0.7 m at 1 m/s
    assert pump.room(apex, flat, 9.81) and not pump.room(apex, step, 9.81)
    assert pump.room(ds.ApexState(-2.0, 0.8, 1.0), step, 9.81)


def test_from_a_start_with_no_plan_the_robot_pumps_on_level_ground_until_it_has_one():
    from drakeslip.multibody.fit import fitted_template
    from planners.drake_system import REPLAN_AT_EVERY_APEX, run_closed_loop

    case = SimpleNamespace(id="step-7714-v1-z0.8", terrain=ds.step_world(7714), apex=(-1.0, 0.8, 1.0))
    config = replace(REPLAN_AT_EVERY_APEX, robot=RobotParams(), map_filter=5)
    result = run_closed_loop("step@robust", case, 6.0, fitted_template().with_friction(0.8), config)
    first = result["plans"][0]
    assert not first["success"] and "pumped" in first and not first["footholds"]
    assert result["success"], result["what"]
    assert any(record["success"] for record in result["plans"])


def test_a_low_start_before_a_high_step_crosses_because_the_robot_pumps_energy():
    """From 0.8 m at 2 m/s the template's only plans over the 0.49 m step skim it with the body less than a leg
    length above it; the robot's leg, swung through under the hip, falls into the step unless the robot raises
    its energy first."""
    from drakeslip.multibody.fit import fitted_template
    from planners.drake_system import REPLAN_AT_EVERY_APEX, run_closed_loop

    case = SimpleNamespace(id="step-7714-v2-z0.8", terrain=ds.step_world(7714), apex=(-1.0, 0.8, 2.0))
    template = fitted_template().with_friction(0.8)
    config = replace(REPLAN_AT_EVERY_APEX, robot=RobotParams(), map_filter=5)
    runs = {pump: run_closed_loop("step@robust", case, 6.0, template, replace(config, pump_energy=pump))
            for pump in (True, False)}
    assert runs[True]["success"], runs[True]["what"]
    assert any("pumped" in record for record in runs[True]["plans"])
    assert not runs[False]["success"] and runs[False]["failure"] == "BODY_COLLISION"
    assert not any("pumped" in record for record in runs[False]["plans"])


def test_under_model_mismatch_the_controller_keeps_the_models_values(monkeypatch):
    """The plant is the drawn robot, the controller is built for the model (as the SLIP's controller is)."""
    import planners.drake_system as drake_system
    from drakeslip.noise import profile

    built = {}

    def build(*args, **kwargs):
        built["hd"] = real_build(*args, **kwargs)
        raise StopIteration   # the diagram is all this test looks at

    real_build = drake_system.build_closed_loop
    monkeypatch.setattr(drake_system, "build_closed_loop", build)
    with pytest.raises(StopIteration):
        drake_system.run_closed_loop("step@robust", ditches_case(), 4.0, ds.SlipParams(),
                                     replace(drake_system.REPLAN_AT_EVERY_APEX, noise=profile("model")))
    hd = built["hd"]
    assert hd.controller.params == RobotParams()
    body_mass = hd.plant.GetBodyByName("body").default_mass()
    assert hd.params.slip != RobotParams().slip and body_mass == pytest.approx(hd.params.slip.mass)
    assert body_mass != pytest.approx(RobotParams().slip.mass)


def test_the_closed_loop_config_switches_the_pump_and_records_it(monkeypatch, run_script):
    """``evaluate.py --no-pump`` reaches the robot's diagram, is part of the results' config (so cached cases of
    the other setting are not reused), and is a usage error on a backend without the robot."""
    import planners.drake_system as drake_system
    from planners.closed_loop import ClosedLoopConfig, run_case

    seen = []

    def run(planner, case, goal_x, params, config):
        seen.append(config.pump_energy)
        raise StopIteration

    monkeypatch.setattr(drake_system, "run_closed_loop", run)
    for pump in (True, False):
        config = ClosedLoopConfig(backend="multibody", pump_energy=pump)
        with pytest.raises(StopIteration):
            run_case("step@robust", None, ditches_case(), 4.0, ds.SlipParams(), config)
        assert config.to_dict()["pump_energy"] is pump
    assert seen == [True, False]
    code, _, err = run_script("evaluate", "--suite", ROOT / "suites" / "ditch.json", "--planners", "step",
                              "--backend", "fast", "--no-pump", "--out", "unused.json")
    assert code == 2 and "--no-pump needs --backend multibody, got --backend fast" in err
