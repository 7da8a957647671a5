"""The map loop on the spatial robot: the planner system in the robot's Diagram, the loop as its state, a gap crossed
to the goal, and evaluate.py's multibody backend on a map suite."""
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


def test_the_robot_crosses_a_gap_to_the_goal_replanning_at_each_apex(gap_case):
    from planners.registry import make
    from planners.spatial_robot_loop import run_map_case_on_robot

    result = run_map_case_on_robot(make("step"), gap_case, ds.SlipParams(),
                                   ClosedLoopConfig(backend="multibody", executed_per_plan=1))
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

