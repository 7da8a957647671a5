"""The planners' pruned last stage (planners/search/pruned.py): it finds what a starved nominal search misses, the plan
it writes is one the controller executes, the energy graph refuses starts with no way on, and its budget is an
option checked like the others."""
import numpy as np
import pytest

import planners
from drakeslip import ApexState, SlipParams, Terrain
from drakeslip.rollout import rollout
from planners.formats.suite import make_suite

PARAMS = SlipParams(friction=0.8)
# a low-energy start before the step family's terrain (0.65 m high at 2.2 m/s), where plans have many hops
LOW_START = make_suite("step", 91000, n_terrains=1, speeds=(2.2,), heights=(0.65,)).cases[0]


@pytest.mark.parametrize("label", ["step", "lstm-guided", "step@robust"])
def test_the_stage_finds_what_a_starved_search_misses_and_the_plan_executes(label):
    apex, terrain = LOW_START.apex, LOW_START.terrain.perceived(LOW_START.apex.x)
    starved = planners.make(label, max_nodes=3, pruned_nodes=0).plan(apex, terrain, 10.0, PARAMS)
    assert not starved.success and "pruned search" not in starved.message
    planner = planners.make(label, max_nodes=3)
    plan = planner.plan(apex, terrain, 10.0, PARAMS)
    assert plan.success and plan.message.startswith("found by pruned search (after ")
    # the plan as written: its footholds, aimed by the controller from where each hop really ends, on the fast map
    run = rollout(apex, terrain, PARAMS, footholds=list(plan.footholds), controller=planner.controller,
                  backend="fast")
    assert run.ok and len(run.footholds) == len(plan.footholds)
    assert np.max(np.abs(np.asarray(run.footholds) - plan.footholds)) < 0.02   # Step-space's landing tolerance
    assert plan.footholds[-1] >= min(10.0, terrain.known_end) - 1.0


def test_a_start_with_no_way_on_is_refused_without_a_search():
    heights = np.zeros(400)
    heights[60:] = 3.0   # a wall far above the energy height (1 + 2^2 / (2 g) = 1.2 m)
    plan = planners.make("step").plan((0.0, 1.0, 2.0), Terrain(heights), 10.0, PARAMS)
    assert not plan.success
    assert plan.message.endswith("pruned search: unreachable)")


def test_the_stage_stops_at_its_node_budget():
    apex, terrain = LOW_START.apex, LOW_START.terrain.perceived(LOW_START.apex.x)
    plan = planners.make("step", max_nodes=3, pruned_nodes=5).plan(apex, terrain, 10.0, PARAMS)
    assert not plan.success and plan.message.endswith("pruned search: nodes)")
    assert plan.nodes_expanded <= 3 * 2 + 5


def test_the_papers_lstm_guided_search_has_no_pruned_stage():
    assert planners.make("lstm-guided@paper").pruned_nodes == 0


@pytest.mark.parametrize("bad", [-1, 1.5, True, "100"])
def test_a_bad_node_budget_is_named(bad):
    with pytest.raises(ValueError, match="pruned_nodes"):
        planners.make("step", pruned_nodes=bad)


def test_the_stage_plans_for_another_hopper_in_its_units():
    """A hopper twice the paper's size on the same terrain made twice as long: the stage still finds the plan."""
    big = SlipParams(mass=14.0, leg_length=1.0, stiffness=3200.0, friction=0.8)
    t = LOW_START.terrain
    terrain = Terrain(t.heights * 2.0, t.cell * 2.0, t.x0 * 2.0).perceived(2.0 * LOW_START.apex.x, 8.0, 2.0)
    apex = ApexState(2.0 * LOW_START.apex.x, 2.0 * LOW_START.apex.z, LOW_START.apex.xdot * np.sqrt(2.0))
    plan = planners.make("step", max_nodes=3).plan(apex, terrain, 20.0, big)
    assert plan.success and "pruned search" in plan.message


def test_the_compiled_dead_apex_check_is_the_energy_graphs():
    """planners/core/pruned.py's ``alive`` drops exactly the apexes ``Coreach.alive`` drops (the oracle's check)."""
    from planners.core.pruned import Coreachable, alive
    from planners.search.energy_graph import CellGraph, Coreach

    terrain = LOW_START.terrain
    graph = CellGraph(LOW_START.apex, terrain, 10.0, PARAMS)
    coreach = Coreach(graph)
    cells = Coreachable(coreach.lo, coreach.hi, coreach.top, float(coreach.top.min(initial=np.inf)))
    rng = np.random.default_rng(0)
    apexes = np.column_stack([rng.uniform(-1.0, 11.0, 400), rng.uniform(0.3, 1.6, 400), rng.uniform(0.05, 3.0, 400)])
    expected = coreach.alive(apexes)
    assert 0 < expected.sum() < len(expected)   # both kinds drawn
    got = [alive(x, z, v, cells, graph.reach, graph.g, 10.0) for x, z, v in apexes]
    assert np.array_equal(got, expected)
