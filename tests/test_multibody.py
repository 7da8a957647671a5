"""The multibody hopper: its model and terrain geometry, the closed loop crossing a ditch, the controller's energy
injection mattering, the leg's swing at touchdown and liftoff, the fitted template, and the robot's replay and
figure (the planner system and the robot's loop: tests/test_multibody_loop.py)."""
import importlib.util
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import drakeslip as ds
from drakeslip.multibody.controller import HeldLeg, apex_energy, touchdown_angle
from drakeslip.multibody.robot import RobotParams, hopper_sdf
from drakeslip.multibody.terrain import terrain_runs

ROOT = Path(__file__).resolve().parents[1]


def example_module():
    spec = importlib.util.spec_from_file_location("hop_multibody", ROOT / "examples" / "hop_multibody.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_terrain_boxes_have_the_maps_heights_and_edges():
    heights = np.array([0.0, 0.0, -1.0, -1.0, 0.1, 0.1, 0.1])
    runs = terrain_runs(ds.Terrain(heights, 0.1, 0.0))
    assert [r[2] for r in runs] == [0.0, -1.0, 0.1]
    assert runs[0][1] == pytest.approx(0.2) and runs[1] == pytest.approx((0.2, 0.4, -1.0))
    assert runs[2][0] == pytest.approx(0.4) and runs[0][0] < -10 and runs[2][1] > 10


def test_the_model_file_takes_the_parameters():
    text = hopper_sdf(RobotParams(body_pitch_inertia=0.4, foot_mass=0.5, slip=ds.SlipParams(friction=0.6)))
    assert "<iyy>0.4</iyy>" in text and "<mass>0.5</mass>" in text and "<drake:mu_dynamic>0.6<" in text
    with pytest.raises(ValueError, match="foot_radius"):
        RobotParams(foot_radius=0.2)


def test_the_controller_and_the_monitor_take_the_robots_geometry_from_its_model():
    """The upper leg's centre of mass and pitch inertia and the body box as Drake parses the model, and the stance
    time in the hopper's time units (the paper's hopper's to the bit)."""
    from pydrake.geometry import Role

    from drakeslip.multibody.gains import STANCE_TIME, stance_time
    from drakeslip.multibody.diagram import build_diagram
    from drakeslip.multibody.failures import HopMonitor
    from drakeslip.multibody.robot import model_geometry

    hd = build_diagram(ds.Terrain.flat(), RobotParams())
    leg, body = hd.plant.GetBodyByName("leg"), hd.plant.GetBodyByName("body")
    com = leg.default_com()
    inertia = leg.default_spatial_inertia().Shift(com).CalcRotationalInertia().CopyToFullMatrix3()
    inspector = hd.scene_graph.model_inspector()
    (box,) = [inspector.GetShape(g) for g in inspector.GetGeometries(hd.plant.GetBodyFrameIdOrThrow(body.index()),
                                                                     Role.kIllustration)]
    geometry = model_geometry(RobotParams())
    assert (geometry.leg_com, geometry.leg_inertia) == pytest.approx((-com[2], inertia[1, 1]), rel=1e-12)
    assert geometry.body_half == pytest.approx((box.width() / 2, box.height() / 2), rel=1e-12)
    assert (hd.controller.leg_com, hd.controller.leg_inertia) == (geometry.leg_com, geometry.leg_inertia)
    assert HopMonitor(hd, ds.Terrain.flat(), hd.diagram.CreateDefaultContext(), None).body_half == geometry.body_half
    assert stance_time(ds.SlipParams()) == STANCE_TIME and hd.controller.scaled.stance_time == STANCE_TIME
    assert stance_time(ds.SlipParams(leg_length=1.0)) == pytest.approx(STANCE_TIME * np.sqrt(2))


def test_the_touchdown_angle_lands_the_foot_on_the_foothold():
    angle = touchdown_angle(0.0, 0.8, 1.5, 0.0, 0.6, 0.0, HeldLeg(0.47, 0.03, 9.81))
    t = np.sqrt(2 * (0.8 - 0.47 * np.cos(angle) - 0.03) / 9.81)
    assert 1.5 * t + 0.47 * np.sin(angle) == pytest.approx(0.6, abs=1e-6)


def ditches_case():
    return SimpleNamespace(id="two-ditches", terrain=example_module().two_ditches(), apex=(0.0, 0.62, 1.5))


@pytest.fixture(scope="module")
def ditches_run():
    """step@robust takes the robot over two short ditches to x = 4 m (its Plans kept), with its trajectory."""
    import planners
    from planners.closed_loop import PlanRecorder
    from planners.drake_system import run_closed_loop

    recorder = PlanRecorder(planners.make("step@robust"))
    return run_closed_loop(recorder, ditches_case(), 4.0, ds.SlipParams(), trajectory=True), recorder


def test_a_multibody_case_crosses_short_ditches(ditches_run):
    """The robot crosses, each touchdown aimed at a plan's foothold and recorded as executed under that plan's
    record, within 2 cm of it."""
    from planners.closed_loop import executed_plans

    result, recorder = ditches_run
    assert result["success"], result["what"]
    assert result["final_x"] >= 4.0 and result["hops"] >= 5 and result["max_pitch"] < 0.5
    planned, predicted = executed_plans(recorder.plans, result["plans"])
    executed = [x for record in result["plans"] for x in record["executed"]]
    assert len(planned) == len(predicted) == len(executed) == result["hops"]
    assert executed == result["log"].footholds and np.abs(np.subtract(executed, planned)).max() < 0.02


def test_without_energy_injection_the_same_case_runs_out_of_energy():
    from planners.drake_system import run_closed_loop

    result = run_closed_loop("step@robust", ditches_case(), 4.0, ds.SlipParams(), inject_energy=False,
                             trajectory=True)
    assert not result["success"] and result["final_x"] < 4.0
    energies = [apex_energy(a.z, a.xdot, 9.81) for a in result["log"].apexes]
    start = apex_energy(0.62, 1.5, 9.81)
    assert len(energies) >= 3 and energies[-1] < start - 1.0 and all(np.diff(energies[:4]) < 0)
    from pydrake.geometry import Meshcat

    from drakeslip.multibody.replay import draw_robot_replay

    meshcat = Meshcat()   # the replay marks and names the failure
    draw_robot_replay(meshcat, result["log"], ditches_case().terrain, fps=10)
    failure = result["log"].failure
    assert failure is not None and all(meshcat.HasPath(f"/drakeslip/world/failure/{p}") for p in ("x", "label"))


def _foot_path(speed: float):
    """The foot ball's centre (x, bottom z) and the absolute leg angle at every step of one hop from an apex at
    ``speed`` onto a foothold on flat ground, with the controller's phase."""
    from drakeslip.multibody.diagram import build_diagram
    from drakeslip.multibody.execute import execute

    terrain = ds.Terrain.flat()
    log = execute((0.0, 0.75, speed), terrain, [0.25 + 0.17 * speed], trajectory=True)
    assert log.failure is None, log.failure
    robot = RobotParams()
    x, z, pitch, hip, leg = np.array(log.positions)[:, list(build_diagram(terrain, robot).layout.q)].T
    angle = pitch + hip
    return (np.array(log.times), x, x + leg * np.sin(angle), z - leg * np.cos(angle) - robot.foot_radius, angle)


def test_the_leg_swings_back_as_it_lands_so_the_foot_meets_the_ground_slower_than_the_body():
    """Ground-speed matching: a foot landing at the body's speed slides before the leg's force holds it."""
    t, x, foot_x, foot_z, angle = _foot_path(2.5)
    first = int(np.argmax(foot_z < 1e-3))   # the first touchdown
    dt = t[first] - t[first - 5]
    foot_speed = (foot_x[first] - foot_x[first - 5]) / dt
    body_speed = (x[first] - x[first - 5]) / dt
    assert angle[first] < angle[first - 5]   # the leg is swinging back
    assert 0.7 * body_speed < foot_speed < 0.9 * body_speed   # about 0.8 (LANDING_SWING_SHARE)


def test_after_liftoff_the_foot_rises_where_it_stood():
    """Until it clears the ground the foot is not dragged forward by the hip (it would catch a step's face)."""
    t, x, foot_x, foot_z, angle = _foot_path(2.5)
    first = int(np.argmax(foot_z < 1e-3))
    liftoff = first + int(np.argmax(foot_z[first:] > 1e-3))
    clear = liftoff + int(np.argmax(foot_z[liftoff:] > 0.03))
    body, foot = x[clear] - x[liftoff], foot_x[clear] - foot_x[liftoff]
    assert clear > liftoff and body > 0.02
    assert abs(foot) < 0.6 * body   # a leg left to swing on by itself lets the hip drag the foot about 2/3 as far


def test_a_speed_error_in_the_apex_estimate_carries_into_where_the_foot_lands():
    """As the SLIP's controller and the robust planner's particles do: a robot told it is faster than it is aims
    from an estimate that runs ahead of it through the descent, and lands short by the error times the fall."""
    from drakeslip.multibody.execute import execute

    terrain = ds.Terrain.flat()
    touched = {e: execute((0.0, 0.75, 2.0), terrain, [0.6], apex_errors=[(0.0, 0.0, e)]).footholds[0]
               for e in (-0.1, 0.0, 0.1)}
    fall = np.sqrt(2 * (0.75 - 0.47 * np.cos(0.25) - 0.03) / 9.81)   # apex to touchdown, about 0.23 s
    for e in (-0.1, 0.1):
        assert touched[e] - touched[0.0] == pytest.approx(-e * fall, rel=0.25)


def test_a_multibody_rollout_builds_its_controller_for_the_model(monkeypatch):
    import drakeslip.multibody.execute as execute_module
    from drakeslip.controller import StepLengthController
    from drakeslip.rollout import rollout

    seen = {}

    def execute(start, terrain, footholds, robot, **kwargs):
        seen.update(robot=robot, known=kwargs["known"])
        raise StopIteration

    monkeypatch.setattr(execute_module, "execute", execute)
    drawn = ds.SlipParams(stiffness=3300.0, mass=7.1)
    with pytest.raises(StopIteration):
        rollout((0.0, 0.8, 1.0), ds.Terrain.flat(), drawn, footholds=[0.3], backend="multibody",
                controller=StepLengthController.load_default(), model=ds.SlipParams())
    assert seen["robot"].slip == drawn and seen["known"].slip == ds.SlipParams()


def test_the_fit_recovers_a_templates_leg_and_spring_from_its_hops():
    from drakeslip.multibody.fit import Hop, errors, fit, predict

    truth = ds.SlipParams(leg_length=0.48, stiffness=3600.0)
    starts = [(0.0, z, v) for z in (0.75, 0.9) for v in (1.0, 1.5, 2.0)]
    hops = [Hop(a, a[0] + 0.12 * a[2] + 0.1, 0.0, (0.0, 0.0, 0.0)) for a in starts]
    hops = [Hop(h.apex, h.foothold, 0.0, tuple(p)) for h, p in zip(hops, predict(hops, truth))]
    fitted = fit(hops, ds.SlipParams())
    assert fitted.leg_length == pytest.approx(0.48, abs=2e-3) and fitted.stiffness == pytest.approx(3600, rel=0.02)
    assert np.nanmax(errors(hops, fitted)[:, :2]) < 2e-3 < np.nanmax(errors(hops, ds.SlipParams())[:, :2])
    assert predict([], truth).shape == (0, 3) and errors([], truth).shape == (0, 3)


def test_the_fit_reports_its_errors_by_the_hops_speed_change():
    from drakeslip.multibody.fit import Hop, by_speed_change

    hops = [Hop((0.0, 0.8, 2.0), 0.5, 0.0, (1.0, 0.8, v)) for v in (0.5, 1.5, 1.6, 3.5)]
    err = np.array([[0.07, 0.02, 0.1], [0.01, 0.0, 0.0], [0.03, 0.0, 0.0], [0.02, 0.0, 0.0]])
    bands = by_speed_change(hops, err)
    assert [b["band"] for b in bands] == [[None, -1.0], [-1.0, 0.0], [1.0, None]]
    assert [b["hops"] for b in bands] == [1, 2, 1]
    assert bands[0]["median_x"] == 0.07 and bands[1]["median_x"] == pytest.approx(0.02)


@pytest.fixture(scope="module")
def robot_page(ditches_run, tmp_path_factory):
    from drakeslip.multibody.replay import write_robot_replay
    from planners.closed_loop import executed_plans

    result, recorder = ditches_run
    planned, predicted = executed_plans(recorder.plans, result["plans"])
    return write_robot_replay(result["log"], ditches_case().terrain, tmp_path_factory.mktemp("robot") / "robot.html",
                              planned, predicted, title="robot over a ditch")


def _body_rgb():
    """The robot's body's colour in the replay: its own (robot.sdf's), no other part's or marker's."""
    from drakeslip.multibody.replay import RobotModel

    return next(tuple(colour.rgba[:3]) for _, name, _, _, colour in RobotModel().parts if name == "body_visual")


def test_the_robot_replay_follows_the_robot_in_headless_chromium(robot_page):
    """The replay fits its window and shows the robot's body at 0.8 s, 2.2 s and the end of the run, at one place
    across the window while the terrain slides under it, with its legs, the planned and executed footholds and the
    predicted apexes."""
    from test_meshcat_replay import assert_body_drawn, near, require_browser, shots

    require_browser()
    from drakeslip import replay_scene as rs

    text = robot_page.read_text()
    assert "<title>robot over a ditch</title>" in text and "no failure" in text and "planned footholds" in text
    images = shots(robot_page, [0.8, 2.2, 9.0], robot_page.parent)
    assert_body_drawn(images, _body_rgb(), rs.HEADER_PX, rs.TERRAIN_RGB)
    scenes = [image[rs.HEADER_PX + 2:] for image in images]
    counts = {name: [near(scene, getattr(rs, f"{name}_RGB")) for scene in scenes]
              for name in ("PLANNED", "PREDICTED", "EXECUTED")}
    counts["upper leg"] = [near(scene, (0.30, 0.30, 0.30), 30) for scene in scenes]
    assert all(max(n) > 100 for n in counts.values()) and max(counts["upper leg"]) > 300, counts


def test_the_robot_check_fails_on_a_page_without_the_robot(robot_page):
    """The same page held at 2.2 s with the robot hidden: the terrain is there, the check of the body fails."""
    from test_meshcat_replay import WINDOW, assert_body_drawn, near, require_browser, shots

    require_browser()
    from drakeslip import replay_scene as rs

    images = shots(robot_page, [2.2], robot_page.parent, hide="/drakeslip/world/robot")
    assert near(images[0][rs.HEADER_PX + 2:], rs.TERRAIN_RGB) > 0.1 * WINDOW[0] * WINDOW[1]
    with pytest.raises(AssertionError, match="the body is not drawn"):
        assert_body_drawn(images, _body_rgb(), rs.HEADER_PX, rs.TERRAIN_RGB)


def test_the_robot_figure_shows_the_whole_path_and_the_leg_at_each_touchdown_and_liftoff(ditches_run):
    from drakeslip.multibody.replay import plot_robot_run
    from drakeslip.viz import LEG_COLOR

    result, _ = ditches_run
    log = result["log"]
    ax = plot_robot_run(log, ditches_case().terrain)
    z = np.array(log.positions)[:, 1]
    assert ax.get_ylim()[0] < 0.0 and ax.get_ylim()[1] > z.max() > 0.6
    legs = [line for line in ax.lines if line.get_color() == LEG_COLOR and len(line.get_xdata()) == 2]
    assert len(legs) == len(log.touchdown_times) + len(log.liftoff_times) >= 2 * result["hops"] - 1
    feet = np.array([line.get_xdata()[1] for line in legs[:result["hops"]]])
    np.testing.assert_allclose(feet, log.footholds, atol=0.01)   # a leg at touchdown ends on its foothold


