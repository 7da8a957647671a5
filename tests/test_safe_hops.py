"""Never stranded: where no sequence reaches the target, a planner with ``safe_hops`` returns the safest branch its
searches grew (``Plan.safe_hops``), the loops fly it, and a plan without it is unchanged."""
from types import SimpleNamespace

import numpy as np
import pytest

import drakeslip as ds
import planners
from drakeslip.controller import StepLengthController
from drakeslip.rollout import rollout
from planners.base import FootstepSequence, Plan, footholds_to_fly
from planners.closed_loop import ClosedLoopConfig, executed_plans, run_case
from planners.replanning import flown_footholds
from planners.search.tree import SAFE_DEPTH

APEX = ds.ApexState(0.5, 0.9, 1.5)


def wide_ditch() -> ds.Terrain:
    """Flat ground with a 6 m ditch from x = 6 m: no hopper crosses it."""
    heights = np.zeros(200)
    heights[60:120] = ds.terrain.DITCH_HEIGHT
    return ds.Terrain(heights, 0.1)


@pytest.fixture(scope="module")
def stranded():
    """step@robust with safe hops, and without, planning past the ditch."""
    terrain = wide_ditch()
    plans = {safe: planners.make("step@robust", safe_hops=safe).plan(APEX, terrain.perceived(APEX.x), 15.0,
                                                                     ds.SlipParams())
             for safe in (True, False)}
    return terrain, plans


def test_with_no_plan_the_safe_hops_are_a_branch_the_hopper_flies_alive(stranded):
    terrain, plans = stranded
    plan = plans[True]
    assert not plan.success and plan.safe_hops is not None
    assert 1 <= len(plan.safe_hops) and plan.safe_hops.footholds[0] > APEX.x
    assert f"{len(plan.safe_hops)} safe hops to x=" in plan.message
    assert plan.summary()["safe_footholds"] == plan.safe_hops.footholds.tolist()
    run = rollout(APEX, terrain, ds.SlipParams(), leg_angles=plan.safe_hops.leg_angles.tolist(),
                  backend="fast")
    assert run.failure is None, run.failure
    np.testing.assert_allclose(run.apexes[-1], plan.safe_hops.apexes[-1], atol=1e-6)


def test_the_safe_branch_is_as_deep_as_the_searches_grew_up_to_the_cap(stranded):
    _, plans = stranded
    assert len(plans[True].safe_hops) >= min(SAFE_DEPTH, 2)


def test_without_the_option_the_plan_is_the_one_it_was(stranded):
    _, plans = stranded
    safe, plain = plans[True], plans[False]
    assert plain.safe_hops is None and "safe_footholds" not in plain.summary()
    assert safe.message.startswith(plain.message + "; ")
    assert (plain.ode_calls, plain.nodes_expanded) == (safe.ode_calls, safe.nodes_expanded)


def test_a_loop_flies_the_safe_hops_but_the_last_and_a_plans_own_first():
    hops = FootstepSequence(np.array([1.0, 2.0, 3.0]), np.zeros(3), np.zeros((3, 3)))
    safe = Plan("step", False, 9.0, safe_hops=hops)
    assert safe.to_fly(3).tolist() == [1.0, 2.0] and safe.to_fly(1).tolist() == [1.0]
    one = Plan("step", False, 9.0, safe_hops=FootstepSequence(np.array([1.0]), np.zeros(1), np.zeros((1, 3))))
    assert one.to_fly(3).tolist() == [1.0]
    found = Plan("step", True, 9.0, sequences=[hops], safe_hops=None)
    assert found.to_fly(2).tolist() == [1.0, 2.0]
    assert Plan("step", False, 9.0).to_fly(3).size == 0
    record = safe.summary()
    assert flown_footholds(record) == [1.0, 2.0]
    assert footholds_to_fly(False, [], None) == []


def test_the_loop_hops_on_toward_the_ditch_instead_of_stopping_at_the_start():
    terrain = wide_ditch()
    case = SimpleNamespace(id="wide-ditch", terrain=terrain, apex=tuple(APEX))
    config = ClosedLoopConfig(executed_per_plan=1, backend="fast")
    controller = StepLengthController.load_default()
    runs = {safe: run_case(planners.make("step@robust", safe_hops=safe), controller, case, 15.0, ds.SlipParams(),
                           config) for safe in (True, False)}
    plain, safe = runs[False], runs[True]
    assert plain["failure"] == "NO_PLAN" and plain["final_x"] == APEX.x and len(plain["plans"]) == 1
    first = safe["plans"][0]
    assert "safe_footholds" in first and first["executed"] == first["safe_footholds"][:1]
    assert safe["final_x"] > APEX.x + 2.0   # it hopped on for metres before the ditch ended its way
    assert not safe["success"]


def test_a_replay_draws_the_safe_hops_that_ran():
    hops = FootstepSequence(np.array([1.0, 2.0, 3.0]), np.zeros(3), np.arange(9.0).reshape(3, 3))
    plans = [Plan("step", False, 9.0, safe_hops=hops), Plan("step", True, 9.0, sequences=[hops]), None]
    records = [{"executed": [1.01]}, {"executed": [2.0, 3.0]}, {"success": False}]
    footholds, apexes = executed_plans(plans, records)
    assert footholds == [1.0, 1.0, 2.0] and [list(a) for a in apexes] == [[0, 1, 2], [0, 1, 2], [3, 4, 5]]
