"""The robust search (planners.search.robust, Step-space's admission): every robot of the particle set flies in one
compiled call across its own hopper and terrain, a search checks every node it pops (goals included) and closes
those that fail, and each robustness level stays within its node budget."""
import re
from dataclasses import replace

import numpy as np
import pytest

import drakeslip as ds
import planners
from drakeslip.controller import StepLengthController
from drakeslip.stepmap import Worlds, step_worlds
from planners.formats.suite import make_suite
from planners.search.robust import Robustness


@pytest.fixture(scope="module")
def controller():
    return StepLengthController.load_default()


def test_one_call_across_worlds_is_each_world_on_its_own():
    terrain, params = ds.step_world(3), ds.SlipParams()
    raised = ds.Terrain(terrain.heights + 0.02, terrain.cell, terrain.x0 + 0.01, terrain.ditch_height)
    variants = [(terrain, params), (raised, replace(params, stiffness=params.stiffness * 0.98, friction=0.6))]
    worlds = Worlds.of(variants)
    rng = np.random.default_rng(0)
    apexes = np.column_stack([rng.uniform(0, 2, 40), rng.uniform(0.8, 1.1, 40), rng.uniform(1, 3, 40)])
    angles = rng.uniform(-0.5, 0.5, 40)
    which = rng.integers(0, 2, 40)
    together = step_worlds(apexes, angles, worlds, which)
    for w, (world, hopper) in enumerate(variants):
        rows = which == w
        alone = ds.step_batch(apexes[rows], angles[rows], world, hopper)
        assert np.array_equal(together.failure[rows], alone.failure)
        np.testing.assert_array_equal(together.next_x[rows], alone.next_x)
        np.testing.assert_array_equal(together.touchdown_x[rows], alone.touchdown_x)
    with pytest.raises(ValueError, match=r"world indices in \[0, 2\), got 2"):
        step_worlds(apexes, angles, worlds, which + 2)
    with pytest.raises(ValueError, match="got nan"):
        step_worlds(apexes, np.where(which == 1, np.nan, angles), worlds, which)
    with pytest.raises(ValueError, match="share"):
        Worlds.of([(terrain, params), (ds.Terrain(terrain.heights[:-1], terrain.cell, terrain.x0), params)])


def test_every_hop_the_robust_level_covers_survives_its_particles(controller):
    """The plan's first ``depth`` footholds, goals included, are the ones the particles survive: flying them again
    along the plan passes at every hop, the last with its way on."""
    suite = make_suite("ditch", seed=1000, n_terrains=2)
    params = ds.SlipParams(friction=suite.friction)
    checked = 0
    for case in suite.cases[::2]:
        terrain = case.terrain.perceived(case.apex.x)
        plan = planners.make("step@robust", controller=controller).plan(case.apex, terrain, suite.goal_x, params)
        found = re.match(r"found by robust \(([\d.]+) sigma, depth (\d)\)", plan.message)
        if not found:
            continue
        rob = Robustness(sigmas=float(found[1]), depth=int(found[2]))
        particles = rob.particles(case.apex, terrain, params)
        for hop, foothold in enumerate(plan.footholds[:rob.depth]):
            passed, ends, _ = rob.fly(particles, np.array([foothold]), controller, terrain,
                                      last=hop == rob.depth - 1)
            assert passed[0], (case.id, hop)
            particles = particles.moved(ends[0])
        checked += rob.depth
    assert checked >= 8


def test_a_level_without_a_robust_sequence_stops_at_its_node_budget(controller):
    """A robust level that finds nothing gives up within its ``max_nodes`` and the next level is tried; the plan
    says which levels ran and how each stopped."""
    suite = make_suite("step", seed=2000, n_terrains=1)
    case, params = suite.cases[7], ds.SlipParams(friction=suite.friction)
    terrain = case.terrain.perceived(case.apex.x)
    strict = {"sigmas": 3.0, "depth": 3, "max_nodes": 7, "relaxed": ()}
    alone = planners.make("step", controller=controller, robustness=strict, fallback_nominal=False)
    result = alone.search(case.apex, terrain, suite.goal_x, params)
    assert not result.tree.goals and result.stop in ("nodes", "exhausted") and result.nodes_expanded <= 7
    planner = planners.make("step", controller=controller, robustness=strict)
    plan = planner.plan(case.apex, terrain, suite.goal_x, params)
    assert plan.success and "found by grid" in plan.message
    assert "robust (3 sigma, depth 3) grid 0.025 m:" in plan.message


def test_the_sampled_robust_search_tries_each_level_once(controller):
    """A lazy LSTM-guided search draws the same samples whatever its branching, so a robust level runs it once;
    the nominal level keeps its fallbacks."""
    suite = make_suite("step", seed=2000, n_terrains=1)
    case, params = suite.cases[7], ds.SlipParams(friction=suite.friction)
    planner = planners.make("lstm-guided@robust", controller=controller,
                            robustness={"sigmas": 3.0, "depth": 3, "max_nodes": 5, "relaxed": ()})
    plan = planner.plan(case.apex, case.terrain.perceived(case.apex.x), suite.goal_x, params)
    assert plan.message.count("robust (3 sigma, depth 3) B=") == 1 and "grid" not in plan.message.split("(after")[1]
