"""pytest-benchmark: one plan of each planner on a ditch terrain from the committed suite's kind."""
import pytest

import planners
from drakeslip import SlipParams, ditch_world
from planners.evaluation import perceived

TERRAIN = perceived(ditch_world(1003), 0.0)
APEX = (0.0, 0.9, 2.0)
PARAMS = SlipParams(friction=0.8)


@pytest.fixture(scope="module")
def controller():
    from drakeslip.controller import StepLengthController
    return StepLengthController.load_default()


@pytest.mark.parametrize("name", ["heuristic", "angle", "step"])
def test_bench_one_plan(benchmark, controller, name):
    planner = planners.make(name, **({"controller": controller} if name == "step" else {}))
    plan = benchmark.pedantic(planner.plan, args=(APEX, TERRAIN, 10.0, PARAMS), rounds=5 if name != "heuristic" else 50,
                              warmup_rounds=1)
    assert plan.success, plan.message
    benchmark.extra_info.update(ode_calls=plan.ode_calls, nodes_expanded=plan.nodes_expanded,
                                footholds=len(plan.footholds))
