"""The robust search (planners.search.robust, Step-space's admission): every robot of the particle set flies in one
compiled call across its own hopper and terrain, a search checks every node it pops (goals included) and closes
those that fail, and each robustness level stays within its node budget."""
import re

import numpy as np
import pytest

import drakeslip as ds
import planners
from drakeslip.controller import StepLengthController
from drakeslip.units import units_of
from planners.formats.suite import make_suite
from planners.core.particles import Worlds, ways_on
from planners.core.robust import RobustCheck
from planners.search.robust import Robustness
from planners.search.tree import clear_of_edges


@pytest.fixture(scope="module")
def controller():
    return StepLengthController.load_default()


def reference_flight(rob, particles, foothold, controller, terrain, last):
    """Robustness.fly's verdict by flying every hop of every particle on its own (``step_batch`` in the particle's
    world), the checks in numpy."""
    w = particles.worlds
    worlds = [(ds.Terrain(w.heights[j], w.cell, w.x0[j], w.ditch_height), ds.SlipParams(*w.params[j]))
              for j in range(len(w.x0))]
    told = particles.states + particles.apex_errors
    angles = np.clip(controller.leg_angles(told, np.full(len(told), foothold), terrain) + particles.angle_errors,
                     -1.5, 1.5)
    ends, robust = [], True
    for i, (state, angle) in enumerate(zip(particles.states, angles)):
        world, hopper = worlds[particles.world[i]]
        r = ds.step_batch(state, [angle], world, hopper)
        seen = r.touchdown_x - particles.shift[i]
        ends.append([r.next_x[0], r.next_z[0], r.next_xdot[0]])
        robust &= bool(r.ok[0] and abs(r.touchdown_x[0] - foothold) <= particles.landing
                       and r.next_xdot[0] >= particles.min_speed
                       and r.next_z[0] - terrain.height_at(r.next_x[0] - particles.shift[i]) >= particles.clearance
                       and terrain.same_level(seen, foothold)[0]
                       and clear_of_edges(terrain, seen, particles.edge_margin)[0])
        if robust and last:
            follow = ds.step_batch(ends[-1], particles.fan, world, hopper)
            good = (follow.ok & (follow.next_xdot >= particles.min_speed)
                    & clear_of_edges(terrain, np.nan_to_num(follow.touchdown_x) - particles.shift[i],
                                     particles.edge_margin))
            robust &= int(good.sum()) >= rob.lookahead
    return robust, np.array(ends)


def test_the_compiled_check_is_every_hop_flown_on_its_own(controller):
    """One compiled call flies every particle with its own hopper over its own terrain (raised or shifted) and
    stops at the first that fails: its verdict on every candidate foothold of a few starts, with and without the
    way-on check, is that of flying every hop alone; a robust flight's next apexes are the same to the bit, and it
    counts the hops it flew, no more than every hop."""
    suite = make_suite("ditch", seed=1000, n_terrains=2)
    params = ds.SlipParams(friction=suite.friction)
    planner = planners.make("step", controller=controller)
    rob = Robustness()
    verdicts = []
    for case in suite.cases[::4]:
        terrain = case.terrain.perceived(case.apex.x)
        particles = rob.particles(case.apex, terrain, params)
        x_l = planner.candidates(case.apex, terrain, params, None)
        for foothold in x_l[np.isfinite(planner.aim(case.apex, x_l, terrain, params))]:
            for last in (False, True):
                robust, ends, hops = rob.fly(particles, foothold, controller, terrain, last)
                expected, expected_ends = reference_flight(rob, particles, foothold, controller, terrain, last)
                assert robust == expected, (case.id, foothold, last)
                assert 1 <= hops <= len(particles.states) * (1 + last * particles.fan.size)
                if robust:
                    np.testing.assert_array_equal(ends, expected_ends)
                verdicts.append(robust)
    assert 20 <= sum(verdicts) <= len(verdicts) - 20, (sum(verdicts), len(verdicts))
    # a second hop after which a robot whose map is shifted finds one way on, judged on its own shifted map (read
    # with another particle's shift, its fan had two)
    apex = (8.126405702506576, 0.8136182100515159, 1.9320474018461449)
    terrain = ds.ditch_world(150014).perceived(apex[0])
    particles = rob.particles(apex, terrain, params)
    passed, ends, _ = rob.fly(particles, 8.7375, controller, terrain, last=False)
    assert passed
    assert not rob.fly(particles.moved(ends), 10.1875, controller, terrain, last=True)[0]
    assert not reference_flight(rob, particles.moved(ends), 10.1875, controller, terrain, last=True)[0]


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
            passed, ends, _ = rob.fly(particles, foothold, controller, terrain, last=hop == rob.depth - 1)
            assert passed, (case.id, hop)
            particles = particles.moved(ends)
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
    passed, ends, _ = rob.fly(particles, plan.footholds[0], controller, terrain, last=False)
    clearance = ends[:, 1] - terrain.height_at(ends[:, 0] - particles.shift)
    assert passed and clearance.min() >= params.leg_length
    high = planners.make("step@robust", controller=controller, robustness={"min_clearance": 3.0})
    assert high.plan(case.apex, terrain, suite.goal_x, params).message.startswith("found by grid")
    with pytest.raises(ValueError, match="min_clearance"):
        Robustness(min_clearance=-0.5)


def test_only_the_last_robust_level_searches_the_fine_grid(controller):
    settings = planners.make("step@robust", controller=controller).attempt_settings(units_of(ds.SlipParams()))
    described = [(None if r is None else (r.sigmas, r.depth), spacing) for r, spacing in settings]
    assert described == [((2.0, 2), 0.025), ((2.0, 1), 0.025), ((1.0, 1), 0.025), ((1.0, 1), 0.01),
                         ((1.0, 1), 0.025), ((1.0, 1), 0.01), (None, 0.025), (None, 0.01)]
    with pytest.raises(ValueError, match="fallback_grids"):
        Robustness(fallback_grids="yes")


def test_a_deeper_way_on_is_every_hop_of_it_flown_on_its_own():
    """``ways_on`` at depth 2 counts the fan's leg angles whose hop works and is followed by a working hop, as
    flying both hops of every pair alone finds, before a ditch where some first hops leave no way on; at depth 1 it
    counts the working hops, and it stops at the count it is asked for."""
    params = ds.SlipParams()
    terrain = ds.ditch_world(150014).perceived(0.0)
    fan = (np.linspace(-0.95, 0.95, 21) * np.arctan(params.friction))[::-1].copy()
    margin, min_speed = 0.02, 0.3

    def working(r, k):
        return bool(r.ok[k] and r.next_xdot[k] >= min_speed
                    and clear_of_edges(terrain, np.array([r.touchdown_x[k]]), margin)[0])

    out = np.empty(8)
    heights = terrain.heights[None, :]
    check = RobustCheck(0, 0, 1, fan, np.zeros((1, 3)), np.zeros(1), np.zeros(1, np.int64), np.zeros(1),
                        Worlds(params.as_array()[None, :], heights, np.array([terrain.x0]), terrain.cell,
                               terrain.ditch_height), 0.0, 0.0, margin, min_speed)
    args = (check, 0, terrain.ground(), out)   # particle 0, in the one world, the map as it is
    deeper_differs = 0
    for x in np.arange(0.0, 4.0, 0.25):
        apex = np.array([x, 0.9, 1.5])
        first = ds.step_batch(apex, fan, terrain, params)
        ok1 = [working(first, k) for k in range(fan.size)]
        ok2 = []
        for k in range(fan.size):
            second = ok1[k] and ds.step_batch((first.next_x[k], first.next_z[k], first.next_xdot[k]), fan, terrain,
                                              params)
            ok2.append(ok1[k] and any(working(second, j) for j in range(fan.size)))
        before = np.zeros(4)   # a SLIP: no correction reads the hop before
        assert ways_on(apex, before, fan, fan.size, 1, *args)[0] == sum(ok1)
        assert ways_on(apex, before, fan, fan.size, 2, *args)[0] == sum(ok2)
        assert ways_on(apex, before, fan, 1, 2, *args)[0] == min(1, sum(ok2))
        deeper_differs += sum(ok2) < sum(ok1)
    assert deeper_differs >= 1


def test_a_robust_planner_searches_last_with_a_quarter_of_its_edge_margin(controller):
    """Footholds 0.3 m clear of every edge leave no sequence over a ditch course; the robust planner's last search,
    0.075 m clear, finds one, every foothold of it at least that far from an edge; without it the plan fails."""
    suite = make_suite("ditch", seed=1000, n_terrains=1)
    params = ds.SlipParams(friction=suite.friction)
    case = suite.cases[0]
    terrain = case.terrain.perceived(case.apex.x)
    wide = planners.make("step@robust", controller=controller, edge_margin=0.3)
    plan = wide.plan(case.apex, terrain, suite.goal_x, params)
    assert plan.success and plan.message.startswith("found by edge margin 0.075 m grid"), plan.message
    assert np.all(clear_of_edges(terrain, plan.footholds, 0.075))
    assert not planners.make("step@robust", controller=controller, edge_margin=0.3,
                             last_resort_margin=None).plan(case.apex, terrain, suite.goal_x, params).success
    assert planners.make("step", controller=controller).last_resort(units_of(params)) is None
    with pytest.raises(ValueError, match="last_resort_margin"):
        planners.make("step@robust", last_resort_margin=1.5)


def test_the_robust_noise_is_a_profile_by_name_or_by_its_fields(run_script, tmp_path):
    """``{"robustness": {"noise": "realistic*3"}}`` as --options gives it is the profile ``--noise`` would give; a
    name that is none, or a value that is not a profile, is refused naming it, in one line before any work."""
    assert Robustness(noise="realistic*3").noise == ds.noise.PROFILES["realistic"].scaled(3.0)
    assert Robustness(noise={"apex": (0.01, 0.0, 0.0)}).noise.apex == (0.01, 0.0, 0.0)
    with pytest.raises(ValueError, match=r"Robustness\.noise must be a noise profile .*got 3"):
        Robustness(noise=3)
    code, out, err = run_script("evaluate", "--suite", "suites/ditch.json", "--planners", "step@robust", "--options",
                                '{"step@robust": {"robustness": {"noise": "nope"}}}', "--out", tmp_path / "r.json")
    assert code == 2 and "--options for step@robust: unknown noise profile 'nope'" in err, err
    assert not (tmp_path / "r.json").exists()
