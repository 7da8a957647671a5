"""Planners on hand-made terrains with known answers, budgets, bad inputs and the search tree."""
import math

import numpy as np
import pytest

import planners
from drakeslip import ApexState, SlipParams, Terrain, ditch_world, step_batch
from drakeslip.terrain import DITCH_HEIGHT
from planners.base import MAX_NODES
from planners.closed_loop import ClosedLoopConfig, run_case
from planners.formats.suite import Case
from planners.registry import labels, make_planners, planner_name

PARAMS = SlipParams(friction=0.8)
NAMES = ["heuristic", "angle", "step"]
# the query tests/test_bench_planners.py times: a ditch terrain of the committed suite's kind, seen from x = 0
BENCH_TERRAIN, BENCH_APEX = ditch_world(1003).perceived(0.0), (0.0, 0.9, 2.0)


@pytest.fixture(scope="module")
def controller():
    from drakeslip.controller import StepLengthController
    return StepLengthController.load_default()


@pytest.fixture(scope="module")
def made(controller):
    return {name: planners.make(name, **({"controller": controller} if name == "step" else {})) for name in NAMES}


def test_unknown_planner_lists_the_known_ones():
    with pytest.raises(ValueError, match="unknown planner 'astar'; known planners: ") as err:
        planners.make("astar")
    assert all(name in str(err.value) for name in NAMES)


@pytest.mark.parametrize("name", NAMES)
def test_flat_ground_plan_moves_straight_to_the_target(made, name):
    plan = made[name].plan((0.0, 1.0, 2.0), Terrain.flat(), 10.0, PARAMS)
    assert plan.success, plan.message
    assert plan.target_x == pytest.approx(7.0)  # the goal is beyond the 8 m window: aim 1 m short of its edge
    assert np.all(np.diff(plan.footholds) > 0) and plan.footholds[0] > 0
    assert plan.footholds[-1] < 8.0  # inside the perception window
    # a plan passes the target, or ends where its next hop would leave the window (a stride from its edge)
    assert plan.footholds[-1] >= plan.target_x or plan.footholds[-1] > 8.0 - 2.0
    assert len(plan.leg_angles) == len(plan.footholds) == len(plan.apexes)
    assert (plan.ode_calls == 0) == (name == "heuristic")


@pytest.mark.parametrize("name", NAMES)
def test_flat_ground_receding_horizon_reaches_the_goal(made, controller, name):
    case = Case("flat", Terrain.flat(length=20.0), ApexState(0.0, 0.9, 2.0))
    result = run_case(made[name], controller, case, 10.0, PARAMS, ClosedLoopConfig(backend="fast"))
    assert result["success"], result
    assert result["final_x"] >= 10.0


@pytest.mark.parametrize("name", NAMES)
def test_ditch_wider_than_any_hop_has_no_plan(made, name):
    heights = np.zeros(230)
    heights[40:] = DITCH_HEIGHT  # ground ends at x = 1 m; nothing to land on for the next 19 m
    plan = made[name].plan((0.0, 1.0, 2.0), Terrain(heights), 10.0, PARAMS)
    assert not plan.success
    assert "no plan" in plan.message and len(plan.footholds) == 0


@pytest.mark.parametrize("name", ["angle", "step"])
def test_node_budget_is_respected(controller, name):
    stage = {"controller": controller, "pruned_nodes": 4} if name == "step" else {}
    planner = planners.make(name, max_nodes=3, **stage)
    plan = planner.plan((0.0, 1.0, 2.0), Terrain.flat(), 10.0, PARAMS)
    assert not plan.success and "nodes" in plan.message
    # one fallback each: Angle-space from B=20 to B=30, Step-space from the 2.5 cm grid to the 1 cm one, then
    # Step-space's pruned stage within its own budget
    assert plan.nodes_expanded <= 3 * 2 + (4 if name == "step" else 0)
    assert ("pruned search: nodes" in plan.message) == (name == "step")


@pytest.mark.parametrize("name", ["angle", "step"])
def test_time_budget_is_respected(controller, name):
    planner = planners.make(name, max_time_s=0.02, max_nodes=MAX_NODES, min_speed=0.0,
                            **({"controller": controller} if name == "step" else {}))
    plan = planner.plan((0.0, 1.0, 2.0), Terrain.flat(length=200.0), 150.0, PARAMS)  # too far for 20 ms
    assert plan.time_s < 0.02 + 0.05


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("apex, match", [((0.0, math.nan, 2.0), "apex.z"), ((0.0, -0.1, 2.0), "not above"),
                                         ((0.0, 1.0, -1.0), "xdot"), ((0.0, 1.0), "apex")])
def test_bad_apex_is_rejected(made, name, apex, match):
    with pytest.raises(ValueError, match=match):
        made[name].plan(apex, Terrain.flat(), 10.0, PARAMS)


def test_bad_goal_terrain_params_and_options_are_rejected(made):
    with pytest.raises(ValueError, match="goal_x"):
        made["angle"].plan((0, 1, 2), Terrain.flat(), math.nan, PARAMS)
    with pytest.raises(TypeError, match="Terrain"):
        made["angle"].plan((0, 1, 2), [0.0] * 10, 10.0, PARAMS)
    with pytest.raises(TypeError, match="SlipParams"):
        made["angle"].plan((0, 1, 2), Terrain.flat(), 10.0, {"friction": 0.8})
    with pytest.raises(ValueError, match="max_nodes"):
        planners.make("angle", max_nodes=0)
    with pytest.raises(ValueError, match="branching"):
        planners.make("angle", branching=0)


def test_angle_search_is_seeded():
    a = planners.make("angle", seed=3).plan((0, 1, 2), Terrain.flat(), 10.0, PARAMS)
    b = planners.make("angle", seed=3).plan((0, 1, 2), Terrain.flat(), 10.0, PARAMS)
    np.testing.assert_array_equal(a.leg_angles, b.leg_angles)


def test_search_tree_paths_are_dynamically_feasible():
    planner = planners.make("angle", n_sequences=3)
    terrain = Terrain.flat()
    result = planner.search((0.0, 1.0, 2.0), terrain, 10.0, PARAMS)
    tree = result.tree
    assert len(tree.goals) == 3 and len(tree.leaves()) > 3
    for seq in list(tree.paths())[:20]:
        apex = np.array([0.0, 1.0, 2.0])
        for foothold, angle, nxt in zip(seq.footholds, seq.leg_angles, seq.apexes):
            res = step_batch(apex, [angle], terrain, PARAMS)
            assert res.ok[0] and res.touchdown_x[0] == pytest.approx(foothold)
            apex = np.array([res.next_x[0], res.next_z[0], res.next_xdot[0]])
            np.testing.assert_allclose(apex, nxt)


def test_step_plan_footholds_are_what_the_controller_hits(made, controller):
    terrain = Terrain.flat()
    plan = made["step"].plan((0.0, 1.0, 2.0), terrain, 10.0, PARAMS)
    apex = np.array([0.0, 1.0, 2.0])
    for foothold, nxt in zip(plan.footholds, plan.apexes):
        res = step_batch(apex, [controller.leg_angle(apex, foothold, terrain)], terrain, PARAMS)
        assert res.ok[0] and abs(res.touchdown_x[0] - foothold) < 0.01
        apex = nxt


def test_heuristic_moves_steps_off_ditches(made):
    heights = np.zeros(230)
    heights[35:45] = DITCH_HEIGHT  # a ditch over 0.5 <= x < 1.5
    plan = made["heuristic"].plan((0.0, 1.0, 2.0), Terrain(heights), 10.0, PARAMS)
    assert plan.success
    assert not np.any((plan.footholds >= 0.5 - 0.03) & (plan.footholds < 1.5 + 0.03))  # clear of it and its edges


def test_step_space_on_the_drake_step_map_agrees_with_the_fast_one(controller):
    """step_map="drake" simulates each candidate on the Drake hybrid simulator: the same verdicts and (to the
    backends' agreement) the same next apexes as the fast step map, for a foothold that keeps the hopper going
    and two either side of the band that does."""
    terrain, apex = Terrain.flat(), (0.0, 1.0, 1.5)
    fast, drake = (planners.make("step", controller=controller, step_map=m) for m in ("fast", "drake"))
    problem = fast.problem(apex, terrain, 10.0, PARAMS, 0.0)
    x_l = np.array([0.4125, 0.5625, 0.7125])
    theta = fast.aim(apex, x_l, terrain, PARAMS)
    ok_fast, apex_fast = fast.simulate(problem, apex, x_l, theta)
    ok_drake, apex_drake = drake.simulate(problem, apex, x_l, theta)
    np.testing.assert_array_equal(ok_fast, [False, True, False])
    np.testing.assert_array_equal(ok_drake, ok_fast)
    np.testing.assert_allclose(apex_drake[1], apex_fast[1], atol=2e-3)
    with pytest.raises(ValueError, match="unknown step_map 'mujoco'"):
        planners.make("step", controller=controller, step_map="mujoco")


def test_the_foothold_grid_covers_every_touchdown_the_friction_cone_reaches():
    """Step-space's (and LSTM-guided's) candidate range must contain every foothold some leg angle inside the
    friction cone lands on: from a fast apex over a ditch the feet land on the far bank, higher than the ditch
    floor under the body (the range once used the floor and missed the footholds that cross at 3 m/s)."""
    from drakeslip.terrain import ditch_world, step_world
    from planners.search.angle_space import FRICTION_MARGIN
    from planners.search.step_space import touchdown_range

    params = SlipParams(friction=0.8)
    rng = np.random.default_rng(0)
    angles = np.linspace(-1.0, 1.0, 201) * FRICTION_MARGIN * math.atan(params.friction)
    over_other_ground = 0
    for k in range(40):
        terrain = (ditch_world if k % 2 else step_world)(int(rng.integers(1000)))
        x = float(rng.uniform(0.0, 8.0))
        apex = (x, terrain.height_at(x) + rng.uniform(0.55, 1.1), rng.uniform(0.5, 4.0))
        if terrain.is_ditch_at(x):
            apex = (x, rng.uniform(0.55, 1.1), apex[2])
        lo, hi = touchdown_range(*apex, terrain, params)
        res = step_batch(apex, angles, terrain, params)
        landed = res.touchdown_x[res.ok]
        assert np.all((landed >= lo - 1e-9) & (landed <= hi + 1e-9)), (k, apex, lo, hi, landed.min(), landed.max())
        over_other_ground += bool(landed.size) and terrain.height_at(landed[0]) != terrain.height_at(x)
    assert over_other_ground >= 5  # the cases the range once got wrong are among those drawn


def plans_the_benchmarked_ditch(planner):
    plan = planner.plan(BENCH_APEX, BENCH_TERRAIN, 10.0, PARAMS)
    assert plan.success, plan.message
    assert plan.footholds[0] > BENCH_APEX[0] - PARAMS.leg_length and plan.footholds[-1] < BENCH_APEX[0] + 8.0
    assert np.all(BENCH_TERRAIN.height_at(plan.footholds) > BENCH_TERRAIN.ditch_height)  # none in a ditch
    return plan


@pytest.mark.parametrize("label", [label for label in labels() if planner_name(label) != "trajopt"])
def test_every_label_plans_the_benchmarked_ditch(controller, label):
    """Every planner name and preset (trajopt: tests/test_trajopt.py) plans the query the benchmarks time, with
    footholds on solid ground inside the window; the learned mode planners with no step-map call."""
    plan = plans_the_benchmarked_ditch(make_planners({label: None}, controller)[label])
    assert (plan.ode_calls == 0) == (planner_name(label) in ("heuristic", "lstm"))


@pytest.mark.slow
@pytest.mark.parametrize("label", ["step", "lstm-guided@paper", "lstm-guided"])
def test_the_benchmarked_ditch_is_planned_on_the_drake_step_map(controller, label):
    """``step_map="drake"`` (every candidate hop simulated on Drake, 15-60 s a plan) plans it too."""
    plans_the_benchmarked_ditch(make_planners({label: {"step_map": "drake", "max_time_s": 300}}, controller)[label])
