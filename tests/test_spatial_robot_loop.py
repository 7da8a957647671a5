"""The map loop on the spatial robot: the planner system in the robot's Diagram, the loop as its state, a gap crossed
to the goal, the run's figure and Meshcat replay (the robot in view in headless
Chromium), and evaluate.py's and plan_and_hop.py's multibody backend on maps."""
import json
import math

import numpy as np
import pytest

import drakeslip as ds
from drakeslip.spatial.heightmap import HeightMap
from planners.replanning import ClosedLoopConfig
from planners.spatial_loop import MapCase, MapLoop

GAP = 0.3   # [m] across the way, from x = 1.5


@pytest.fixture(scope="module")
def gap_case():
    heights = np.zeros((40, 140))
    heights[:, 35:35 + round(GAP / 0.05)] = np.nan
    return MapCase("gap", HeightMap(heights, 0.05, (-0.25, -1.0)), (0.0, 0.0, 0.7, 1.5, 0.0), (5.0, 0.0))


@pytest.fixture(scope="module")
def gap_run(gap_case):
    """The gap case on the robot, step replanning at each apex, with its trajectory."""
    from planners.registry import make
    from planners.spatial_robot_loop import run_map_case_on_robot

    return run_map_case_on_robot(make("step"), gap_case, ds.SlipParams(),
                                 ClosedLoopConfig(backend="multibody", executed_per_plan=1), trajectory=True)


def test_the_robot_crosses_a_gap_to_the_goal_replanning_at_each_apex(gap_run):
    result = gap_run
    assert result["success"], (result["failure"], result["what"])
    assert result["final"][0] > 4.0 and abs(result["final"][1]) < 1.0
    assert result["hops"] >= 5 and max(result["max_roll"], result["max_pitch"]) < 0.3
    flown = [f for plan in result["plans"] for f in plan["executed"]]
    assert len(flown) == result["hops"]   # the run ends at the apex after the hop that passes the goal
    assert not any(1.5 <= f[0] < 1.5 + GAP for f in flown)   # no foothold in the gap
    assert all(plan["success"] for plan in result["plans"])


def test_the_loop_is_the_planner_systems_state_replaced_at_each_apex(gap_case):
    """A copy of the loop changes apart from it, and the system never changes the loop it started from."""
    from planners.registry import make
    from planners.spatial_robot_loop import LoopState, MapPlannerSystem
    from drakeslip.spatial.multibody.diagram import build_spatial_diagram

    config = ClosedLoopConfig(backend="multibody", executed_per_plan=1)
    loop = MapLoop(make("step"), gap_case, ds.SlipParams(), config)
    twin = loop.copy()
    assert twin.next_foothold(gap_case.apex) is not None
    assert len(twin.plans) == 1 and loop.plans == [] and loop.hops == 0

    sd = build_spatial_diagram(gap_case.terrain, make_planner=lambda layout: MapPlannerSystem(loop, layout))
    context = sd.diagram.CreateDefaultContext()
    planner_context = sd.planner.GetMyMutableContextFromRoot(context)
    state = np.zeros(sd.layout.size)
    state[list(sd.layout.quaternion)] = (1.0, 0.0, 0.0, 0.0)
    state[list(sd.layout.position)] = gap_case.apex[:3]
    state[list(sd.layout.linear[:2])] = gap_case.apex[3:5]
    command = sd.planner.start_at(planner_context, state)
    assert command.stamp == 0 and len(command.footholds) == 1
    assert isinstance(planner_context.get_abstract_state(1).get_value(), LoopState)
    assert sd.planner.loop(planner_context).hops == 1 and loop.hops == 0 and loop.plans == []


def test_evaluate_runs_a_map_suite_on_the_spatial_robot(run_script, tmp_path, gap_case):
    from planners.formats.map_suite import MAP_SUITE_FORMAT, map_digest

    gap_case.terrain.save(tmp_path / "gap.npz")
    record = {"file": "gap.npz", "sha256": map_digest(gap_case.terrain)}
    apex = dict(zip(("x", "y", "z", "xdot", "ydot"), gap_case.apex))
    (tmp_path / "s.json").write_text(json.dumps({
        "format": MAP_SUITE_FORMAT, "name": "gap-robot", "goal": {"x": 5.0, "y": 0.0}, "friction": 0.8,
        "cases": [{"id": "gap", "map": record, "apex": apex}]}))
    code, out, err = run_script("evaluate", "--suite", tmp_path / "s.json", "--planners", "step", "--backend",
                                "multibody", "--executed", 1, "--quiet", "--out", tmp_path / "r.json")
    assert code == 0, err
    results = json.loads((tmp_path / "r.json").read_text())
    (case,) = results["planners"]["step"]["cases"]
    config = results["planners"]["step"]["config"]
    assert case["success"] and case["hops"] >= 5 and math.isfinite(case["wall_s"])
    assert config["backend"] == "multibody" and config["robot"]["model"] == "drakeslip/spatial/multibody/robot.sdf"



def test_the_logged_trajectory_follows_the_run(gap_run):
    log = gap_run["log"]
    times = np.asarray(log.times)
    assert len(times) > 200 and np.all(np.diff(times) > 0)
    assert times[-1] == pytest.approx(gap_run["simulated_s"], abs=0.02)
    assert all(len(q) == len(log.positions[0]) for q in log.positions)


def test_the_replay_shows_the_robots_own_geometry_over_the_map(gap_run, gap_case, tmp_path):
    from pydrake.geometry import Meshcat

    from drakeslip.spatial.multibody.replay import SpatialRobotModel, draw_spatial_robot_replay, \
        write_spatial_robot_replay

    log = gap_run["log"]
    model = SpatialRobotModel(gap_run["robot"])
    meshcat = Meshcat()
    frames = draw_spatial_robot_replay(meshcat, log, gap_case.terrain, [(1.0, 0.0, 0.0)], model, fps=20)
    assert frames == pytest.approx((log.times[-1] - log.times[0]) * 20, abs=2)
    for path in ("robot/body/body_visual", "robot/gimbal/gimbal_visual", "robot/leg/leg_visual",
                 "robot/foot/shin_visual", "robot/foot/foot_visual", "terrain/0", "planned/0", "executed/3", "path"):
        assert meshcat.HasPath(f"/drakeslip/world/{path}"), path
    empty = type(log)()
    with pytest.raises(ValueError, match="trajectory"):
        draw_spatial_robot_replay(meshcat, empty, gap_case.terrain, model=model)
    page = write_spatial_robot_replay(log, gap_case.terrain, tmp_path / "robot.html", title="a gap")
    text = page.read_text()
    assert "<title>a gap</title>" in text and "no failure" in text and "hip gimbal" in text


@pytest.fixture(scope="module")
def robot_page(gap_run, gap_case, tmp_path_factory):
    from drakeslip.spatial.multibody.replay import write_spatial_robot_replay

    flown = [f for plan in gap_run["plans"] for f in plan["executed"]]
    return write_spatial_robot_replay(gap_run["log"], gap_case.terrain,
                                      tmp_path_factory.mktemp("robot") / "robot.html", flown, robot=gap_run["robot"])


def body_masks(images) -> list:
    from drakeslip.replay_scene import HEADER_PX
    from drakeslip.spatial.multibody.replay import SpatialRobotModel
    from test_meshcat_replay import near_mask

    (body,) = [colour.rgba[:3] for link, name, _, _, colour in SpatialRobotModel().parts if name == "body_visual"]
    return [near_mask(image[HEADER_PX + 2:], body, 45) for image in images]


def test_the_robot_stays_in_view_in_headless_chromium(robot_page):
    """The robot's body shows at the start, mid-run and at the end, at one place across the window (the camera
    follows it), with the footholds drawn."""
    from test_meshcat_replay import near, require_browser, shots

    from drakeslip.replay_scene import EXECUTED_RGB, HEADER_PX, PLANNED_RGB

    require_browser()
    images = shots(robot_page, [0.3, 1.5, 10.0], robot_page.parent)
    bodies = body_masks(images)
    counts = [int(b.sum()) for b in bodies]
    assert min(counts) > 300, f"the body is not drawn in every screenshot: {counts} pixels of its colour"
    width = bodies[0].shape[1]
    columns = [float(np.nonzero(b)[1].mean()) for b in bodies]
    assert 0.2 * width < min(columns) and max(columns) < 0.8 * width and max(columns) - min(columns) < 0.08 * width
    scenes = [image[HEADER_PX + 2:] for image in images]
    assert near(scenes[-1], EXECUTED_RGB) > 20 and all(near(scene, PLANNED_RGB) > 20 for scene in scenes)


def test_the_body_check_fails_where_the_robot_is_hidden(robot_page):
    from test_meshcat_replay import require_browser, shots

    require_browser()
    images = shots(robot_page, [1.5], robot_page.parent, hide="/drakeslip/world/robot")
    assert int(body_masks(images)[0].sum()) < 20


def test_the_figure_draws_the_robots_run(gap_run, gap_case, tmp_path):
    from drakeslip.spatial.multibody.replay import plot_spatial_robot_run

    figure = plot_spatial_robot_run(gap_run["log"], gap_case.terrain, None, "a gap", gap_run["robot"],
                                    goal=gap_case.goal)
    top = figure.axes[0]
    assert top.get_title() == "a gap"
    path = [line for line in top.get_lines() if line.get_label() == "body path"]
    assert path and path[0].get_xdata().max() > 4.0
    figure.savefig(tmp_path / "run.png")
    assert (tmp_path / "run.png").stat().st_size > 20_000
