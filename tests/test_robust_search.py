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


def test_robust_hops_keep_the_apex_a_leg_length_above_the_ground(controller):
    """Every particle's next apex must clear the ground under it by ``min_clearance`` leg lengths: a bar no hop
    reaches leaves every robust level empty, and the particles of a robust plan clear the default bar."""
    suite = make_suite("step", seed=2000, n_terrains=1)
    case, params = suite.cases[7], ds.SlipParams(friction=suite.friction)
    terrain = case.terrain.perceived(case.apex.x)
    plan = planners.make("step@robust", controller=controller).plan(case.apex, terrain, suite.goal_x, params)
    assert plan.message.startswith("found by robust (2 sigma, depth 2)")
    rob = Robustness()
    particles = rob.particles(case.apex, terrain, params)
    passed, ends, _ = rob.fly(particles, plan.footholds[:1], controller, terrain, last=False)
    clearance = ends[0][:, 1] - terrain.height_at(ends[0][:, 0] - particles.shift)
    assert passed[0] and clearance.min() >= params.leg_length
    high = planners.make("step@robust", controller=controller, robustness={"min_clearance": 3.0})
    assert high.plan(case.apex, terrain, suite.goal_x, params).message.startswith("found by grid")
    with pytest.raises(ValueError, match="min_clearance"):
        Robustness(min_clearance=-0.5)


def test_only_the_last_robust_level_searches_the_fine_grid(controller):
    settings = planners.make("step@robust", controller=controller).attempt_settings()
    described = [(None if r is None else (r.sigmas, r.depth), spacing) for r, spacing in settings]
    assert described == [((2.0, 2), None), ((2.0, 1), None), ((1.0, 1), None), ((1.0, 1), 0.01),
                         (None, None), (None, 0.01)]
    with pytest.raises(ValueError, match="fallback_grids"):
        Robustness(fallback_grids="yes")
