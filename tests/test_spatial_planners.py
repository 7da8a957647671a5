"""The planners on height maps: the same labels, one interface (``plan(apex, height_map, (x, y))``); Step-space's
plans are flown exactly by the compiled step map, go round what they cannot cross, and the loop reaches the goal."""
import math

import numpy as np
import pytest

import drakeslip as ds
import planners
from drakeslip.spatial.families import height_map_family
from drakeslip.spatial.heightmap import HeightMap
from drakeslip.spatial.stepmap import step3d
from planners.formats.map_case_record import check_map_case_record
from planners.replanning import ClosedLoopConfig
from planners.spatial_loop import MapCase, MapLoop, passes_goal, run_map_case

P = ds.SlipParams()
START = (-1.0, 0.0, 0.9, 1.5, 0.0)


def walled_map():
    """Flat ground with a band of holes 1.5 m wide across the path (no hop crosses it) but for an opening at
    y in [1, 2)."""
    cell, x0, y0 = 0.05, -3.0, -3.0
    h = np.zeros((120, 400))
    x, y = x0 + (np.arange(400) + 0.5) * cell, y0 + (np.arange(120) + 0.5) * cell
    wall, opening = (x >= 3.0) & (x < 4.5), (y >= 1.0) & (y < 2.0)
    h[np.ix_(~opening, wall)] = np.nan
    return HeightMap(h, cell, (x0, y0))


def last_hop(plan, body):
    """The plan's last foothold and where its hop's way starts (the foothold before it, or the body)."""
    before = plan.footholds[-2] if len(plan.footholds) > 1 else body
    return before, plan.footholds[-1]


@pytest.fixture(scope="module")
def step_planner():
    return planners.make("step")


@pytest.mark.parametrize("family", ["gaps", "stones", "stairs", "blocks", "course"])
def test_step_space_plans_are_flown_exactly(step_planner, family):
    """Every planned hop, flown from the plan's own apexes with its leg angles, lands within the tolerance of its
    foothold on solid ground and reaches the planned apex; the last foothold passes the target."""
    height_map = height_map_family(family)(21, 0.3)
    plan = step_planner.plan(START, height_map, (6.0, 0.0), P)
    assert plan.success, plan.message
    assert plan.footholds.shape[1] == 3 and plan.leg_angles.shape[1] == 2 and plan.apexes.shape[1] == 5
    apex = START
    for foothold, legs, predicted in zip(plan.footholds, plan.leg_angles, plan.apexes):
        assert math.acos(math.cos(legs[0]) * math.cos(legs[1])) < P.max_leg_angle
        hop = step3d(apex, legs, height_map, P)
        assert hop.ok and math.dist(hop.foothold[:2], foothold[:2]) < 0.02
        assert not height_map.is_hole_at(*foothold[:2]) and foothold[2] == height_map.height_at(*foothold[:2])
        assert np.allclose(hop.next_apex, predicted, rtol=0, atol=1e-12)
        apex = tuple(predicted)
    assert passes_goal(*last_hop(plan, START), (plan.target_x, plan.target_y), 0.5)
    again = step_planner.plan(START, height_map, (6.0, 0.0), P)
    assert np.array_equal(again.footholds, plan.footholds) and again.ode_calls == plan.ode_calls


def test_a_plan_goes_round_what_it_cannot_cross(step_planner):
    plan = step_planner.plan(START, walled_map(), (7.0, 0.0), P)
    assert plan.success, plan.message
    inside = plan.footholds[(plan.footholds[:, 0] >= 3.0) & (plan.footholds[:, 0] < 4.5)]
    assert len(inside) >= 1 and np.all((inside[:, 1] >= 1.0) & (inside[:, 1] < 2.0))
    assert plan.footholds[-1, 0] >= plan.target_x


def test_a_hop_reaches_the_goal_when_its_way_passes_within_the_radius():
    """The finish is the goal's disk, met by the way between two footholds: a hop that passes by the goal reaches it
    wherever it lands, and one that passes it aside does not, whatever it lands behind it."""
    goal = (10.0, 0.0)
    assert passes_goal((9.0, 0.0), (11.0, 0.3), goal, 0.5)            # passes 0.15 m from it, lands 1.04 m away
    assert passes_goal((9.2, 0.1), (9.7, 0.2), goal, 0.5)             # lands within the disk, short of the goal
    assert not passes_goal((9.0, 1.0), (11.0, 0.9), goal, 0.5)        # passes 0.95 m aside
    assert not passes_goal((11.5, 1.0), (12.5, 0.2), goal, 0.5)       # lands on the way, 2.5 m past the goal
    assert not passes_goal((9.0, 0.0), (9.4, 0.0), goal, 0.5)         # stops 0.6 m short


@pytest.mark.parametrize("label", ["step", "lstm-guided", "heuristic"])
def test_beside_the_goal_a_plan_passes_within_its_radius(label):
    """The body 0.6 m from the goal, 0.45 m beside the path, on a ledge along the path that ends 0.5 m past the
    goal: the plan's last hop passes within the goal's radius, and no hop before it does (the plan ends there)."""
    cell, x0, y0 = 0.05, 8.0, -1.0
    x, y = x0 + (np.arange(80) + 0.5) * cell, y0 + (np.arange(50) + 0.5) * cell
    h = np.full((50, 80), np.nan)
    h[np.ix_(np.abs(y - 0.45) < 0.2, x < 10.5)] = 0.0
    goal, body = (10.0, 0.0), (9.4, 0.45, 0.9, 1.5, 0.0)
    plan = planners.make(label).plan(body, HeightMap(h, cell, (x0, y0)), goal, P)
    assert plan.success, plan.message
    ways = list(zip([body] + list(plan.footholds[:-1]), plan.footholds))
    assert passes_goal(*ways[-1], goal, 0.5) and not any(passes_goal(*w, goal, 0.5) for w in ways[:-1])


@pytest.mark.parametrize("label", ["step", "lstm-guided"])
def test_a_body_within_the_goal_s_radius_is_one_hop_from_it(label):
    """From a body 0.22 m from the goal, running off to the side, the first hop's way starts within the radius."""
    goal, body = (10.0, 0.0), (10.14, -0.22, 0.55, 2.7, -1.7)
    plan = planners.make(label).plan(body, HeightMap.flat(), goal, P)
    assert plan.success and len(plan.footholds) == 1, plan.message


def test_the_loop_s_way_starts_at_a_plan_s_apex_then_follows_its_footholds(step_planner):
    """The loop asks the plan's search's test: the first hop of a plan from the apex the plan was made from, each
    later one from the foothold flown before it."""
    loop = MapLoop(step_planner, MapCase("flat", HeightMap.flat(), START, (6.0, 0.0)), P, ClosedLoopConfig())
    assert loop.before == START[:2]
    apex = (1.0, 0.1, 0.9, 1.5, 0.0)
    loop.command(apex, 0)
    first = loop.plans[0]["executed"][0]
    assert loop.before == tuple(first) and len(loop.queue) == 2
    loop.command(apex, 1)
    assert loop.before == tuple(loop.plans[0]["executed"][1])


def test_the_heuristic_says_so_when_its_gait_misses_the_goal():
    """0.9 m from the goal and running off to the side, the gait turns too slowly to pass within the goal's radius:
    it leaves the window, and the plan says so instead of ending at the window's edge as if it had arrived."""
    plan = planners.make("heuristic").plan((9.6, -0.8, 0.55, 2.7, -1.7), HeightMap.flat(), (10.0, 0.0), P)
    assert not plan.success and "without reaching the goal" in plan.message, plan.message


def test_a_robust_plan_s_hops_survive_every_particle():
    """``step@robust`` on a map: every hop of its plan, flown from the apex the plan has there by each of the robust
    check's particles (the apex told off, the leg off, another spring, mass and friction), lands on its foothold's
    level and keeps going; some nominal plan has a hop that some particle does not survive."""
    from planners.search.robust import Robustness
    from planners.search.spatial_step import robust_particles

    particles = robust_particles(Robustness(), P, Robustness().sigmas)

    def all_survive(plan, height_map):
        told = [START] + [tuple(a) for a in plan.apexes[:-1]]
        for apex, legs, foothold in zip(told, plan.leg_angles, plan.footholds):
            for errors, params in zip(particles.errors, particles.params):
                hop = step3d(tuple(np.array(apex) - errors[:5]), tuple(legs + errors[5:]), height_map,
                             ds.SlipParams(*params))
                if not (hop.ok and abs(hop.foothold[2] - foothold[2]) <= 0.02):
                    return False
        return True

    fragile = 0
    for seed in range(3):
        height_map = height_map_family("stairs")(30 + seed, 0.6)
        robust, nominal = (planners.make(label).plan(START, height_map, (6.0, 0.0), P)
                           for label in ("step@robust", "step"))
        assert robust.success and "robust" in robust.message, robust.message
        assert all_survive(robust, height_map)
        fragile += not all_survive(nominal, height_map)
    assert fragile >= 1


def test_the_heuristic_plans_on_a_map_without_simulating():
    plan = planners.make("heuristic").plan(START, HeightMap.flat(), (6.0, 1.0), P)
    assert plan.success and plan.ode_calls == 0 and plan.footholds.shape[1] == 3
    assert plan.footholds[-1, 0] >= plan.target_x - 0.5


@pytest.mark.parametrize("label, message", [
    ("trajopt", "plans on profiles"), ("angle", "plans on profiles")])
def test_what_does_not_plan_on_maps_says_so(label, message):
    with pytest.raises(ValueError, match=message) as error:
        planners.make(label).plan(START, HeightMap.flat(), (6.0, 0.0), P)
    assert "\n" not in str(error.value)


@pytest.mark.parametrize("goal, message", [(6.0, "point"), ((6.0, math.nan), "goal y"), ((1e9, 0.0), "goal x")])
def test_bad_goals_and_apexes_are_refused(step_planner, goal, message):
    with pytest.raises(ValueError, match=message):
        step_planner.plan(START, HeightMap.flat(), goal, P)
    with pytest.raises(ValueError, match="no horizontal speed"):
        step_planner.plan((0.0, 0.0, 0.9, 0.0, 0.0), HeightMap.flat(), (6.0, 0.0), P)
    with pytest.raises(ValueError, match="apex must be"):
        step_planner.plan((0.0, 0.9, 1.5), HeightMap.flat(), (6.0, 0.0), P)


@pytest.mark.parametrize("backend", ["fast", "drake"])
def test_the_loop_reaches_a_goal_round_a_wall(step_planner, backend):
    case = MapCase("walled", walled_map(), START, (7.0, 0.0))
    result, sim = run_map_case(step_planner, case, P, ClosedLoopConfig(backend=backend))
    assert result["success"], result
    assert (sim is not None) == (backend == "drake")
    executed = [f for plan in result["plans"] for f in plan["executed"]]
    assert any(3.0 <= x < 4.5 and 1.0 <= y < 2.0 for x, y, _ in executed)
    if sim is not None:   # the controller lands the Drake hopper on every foothold it aims at
        assert len(sim.footholds) == len(executed)
        assert max(math.dist(a[:2], b[:2]) for a, b in zip(sim.footholds, executed)) < 1e-6


@pytest.mark.parametrize("backend", ["fast", "drake"])
def test_the_loop_runs_noise_on_maps(step_planner, backend):
    """Under a noise profile the loop plans from the apex it is told and flies the executed hopper on the true map:
    the feet land near, not on, the footholds aimed at, and on Drake the simulation runs that hopper. (Whether it
    reaches the goal is tests/test_spatial_noise.py's, over several cases.)"""
    from drakeslip.noise import profile

    case = MapCase("flat", HeightMap.flat(), START, (5.0, 0.0))
    config = ClosedLoopConfig(backend=backend, executed_per_plan=1, noise=profile("realistic"))
    result, sim = run_map_case(step_planner, case, P, config)
    executed = ds.SlipParams(**result["executed_params"])
    assert executed != P and all(p["seen_apex"] != p["apex"] for p in result["plans"])
    aimed = [f for plan in result["plans"] for f in plan["executed"]]
    assert len(aimed) >= 3 and (sim is not None) == (backend == "drake")
    if sim is not None:
        misses = [math.dist(a[:2], b[:2]) for a, b in zip(sim.footholds, aimed)]
        assert sim.params == executed and len(sim.footholds) == len(aimed) and 0 < max(misses) < 0.05, misses


def chasm_map():
    """Flat ground with holes from x = 3 m on, across the whole map: no hop gets past x = 3 m."""
    cell, x0, y0 = 0.05, -3.0, -3.0
    h = np.zeros((120, 400))
    h[:, int((3.0 - x0) / cell):] = np.nan
    return HeightMap(h, cell, (x0, y0))


@pytest.fixture(scope="module")
def stranded():
    """Step-space with safe hops, and without, planning past the chasm."""
    return {safe: planners.make("step", safe_hops=safe).plan(START, chasm_map(), (8.0, 0.0), P)
            for safe in (True, False)}


def test_with_no_plan_on_a_map_the_safe_hops_are_a_branch_flown_alive(stranded):
    assert not stranded[False].success and stranded[False].safe_hops is None and len(stranded[False].to_fly()) == 0
    plan, height_map = stranded[True], chasm_map()
    assert not plan.success and plan.safe_hops is not None and "safe hops to (" in plan.message
    safe = plan.safe_hops
    assert len(safe) == len(safe.footholds) >= 2 and safe.footholds.shape[1] == 3
    apex = START
    for foothold, legs, predicted in zip(safe.footholds, safe.leg_angles, safe.apexes):
        hop = step3d(apex, legs, height_map, P)
        assert hop.ok and math.dist(hop.foothold[:2], foothold[:2]) < 0.02 and foothold[0] < 3.0
        assert np.allclose(hop.next_apex, predicted, rtol=0, atol=1e-12)
        apex = tuple(predicted)
    assert np.array_equal(plan.to_fly(3), safe.footholds[:min(3, len(safe) - 1)])


def test_the_map_loop_flies_the_safe_hops_instead_of_stopping():
    """Where no plan exists the loop keeps hopping on the safe hops it is given, alive, until the hop cap; without
    them it stops at the first plan."""
    case = MapCase("chasm", chasm_map(), START, (8.0, 0.0))
    config = ClosedLoopConfig(backend="fast", max_hops=6)
    alive, _ = run_map_case(planners.make("step", safe_hops=True), case, P, config)
    stopped, _ = run_map_case(planners.make("step"), case, P, config)
    assert stopped["failure"] == "NO_PLAN" and len(stopped["plans"]) == 1 and not stopped["plans"][0]["executed"]
    assert alive["failure"] == "HOP_CAP" and all("safe_footholds" in p for p in alive["plans"])
    executed = [f for p in alive["plans"] for f in p["executed"]]
    assert len(executed) == 6 and all(x < 3.0 for x, _, _ in executed)


class FindsOnce:
    """Step-space's plan on the first call; after it, the plan a search that finds nothing returns."""

    def __init__(self, step_planner):
        self.step, self.calls = step_planner, 0
        self.nothing = step_planner.plan(START, chasm_map(), (8.0, 0.0), P)

    def plan(self, apex, height_map, goal, params):
        self.calls += 1
        return self.step.plan(apex, height_map, goal, params) if self.calls == 1 else self.nothing


def test_where_a_replan_finds_nothing_the_loop_flies_on_along_the_last_plan(step_planner):
    """A replan that finds no sequence leaves the robot on the one it is flying: the loop flies the rest of the last
    plan found, planning again before each few hops, and reaches the goal that plan reached."""
    case = MapCase("flat", HeightMap.flat(), START, (6.0, 0.0))
    planner = FindsOnce(step_planner)
    result, _ = run_map_case(planner, case, P, ClosedLoopConfig(backend="fast"))
    first = result["plans"][0]
    assert first["success"] and len(first["footholds"]) > 6
    assert result["success"], result
    later = result["plans"][1:]
    assert later and not any(p["success"] for p in later)
    assert [p["flies_on"] for p in later] == list(range(len(first["footholds"]) - 3, 0, -3))
    assert [f for p in result["plans"] for f in p["executed"]] == first["footholds"]
    assert planner.calls == len(result["plans"])
    assert check_map_case_record(result) is result
    result["plans"][1]["flies_on"] = -1
    with pytest.raises(ValueError, match="flies_on"):
        check_map_case_record(result)


def test_the_guided_search_flies_its_cells_at_each_grid_spacing_then_the_grids():
    """On a map the guided search tries the model's cells at their centres (10 cm apart), then with points 5 cm apart,
    then 2.5 cm apart (Step-space's two grids), each search widening a node from 4 cells to 8, then Step-space's grids
    themselves unless told not to, before it gives up."""
    cells = [f"4, then 8 model cells a node at {s} cm" for s in ("10", "5", "2.5")]
    for fallback, grids in ((True, ["5 cm grid", "2.5 cm grid"]), (False, [])):
        plan = planners.make("lstm-guided", map_grid_fallback=fallback).plan(START, chasm_map(), (8.0, 0.0), P)
        assert not plan.success
        assert [s.split(":")[0] for s in plan.message.split("(", 2)[2].rstrip(")").split("; ")] == cells + grids


def test_a_guided_node_widens_to_its_next_cells_when_the_search_comes_back_to_it():
    """A node's first expansion flies its 4 most probable cells and says it has more; the second flies the next 4
    and says it has none. Together they fly what one expansion of 8 cells flies, and no foothold twice."""
    from planners.core.clock import N_SLOTS
    from planners.core.spatial_sampled import expand_spatial_sampled, start_sampled_spatial
    from planners.core.spatial_tree import new_tree
    from planners.learned.spatial_guided import sampled_expansion
    from planners.search.spatial_problem import spatial_problem
    from planners.search.spatial_step import SpatialStepSettings

    problem = spatial_problem(START, height_map_family("blocks")(3, 0.5), (8.0, 0.0), P, None, 0.0, 60.0)
    tree = new_tree(np.array(START))

    def expansions(tiers):
        expansion = sampled_expansion(problem, SpatialStepSettings(), planners.checkpoints.SPATIAL_WEIGHTS, tiers,
                                      0.05)
        state, _ = start_sampled_spatial(expansion, 0, np.array(START))
        found = []
        for _ in range(len(tiers)):
            children, state = expand_spatial_sampled(expansion, state, tree, np.int64(1), np.int64(0),
                                                     np.zeros(N_SLOTS))
            found.append(children)
        return found

    first, second = expansions((4, 8))
    (together,) = expansions((8,))
    assert first.more and not second.more and not together.more
    assert len(first.footholds) > 0 and second.ode_calls > 0
    assert first.ode_calls + second.ode_calls == together.ode_calls
    widened = {tuple(f) for f in np.vstack([first.footholds, second.footholds])}
    assert len(widened) == len(first.footholds) + len(second.footholds)
    assert widened == {tuple(f) for f in together.footholds}


class Searched(Exception):
    """Raised in place of the guided search, carrying the settings it was given."""


@pytest.mark.parametrize("label, options, weights, sequences, fallback", [
    ("lstm-guided", {}, (1.0, 1.0, 2.0), 1, None),
    ("lstm-guided", {"cost_weights": (1.0, 0.0, 2.0), "n_sequences": 2, "fallback_spacing": (0.01,)},
     (1.0, 0.0, 2.0), 2, (0.01,)),
    ("lstm", {}, (1.0, 1.0, 2.0), 1, None)])
def test_the_guided_search_on_a_map_takes_the_planner_s_weights_and_sequences(monkeypatch, label, options, weights,
                                                                            sequences, fallback):
    """The map search's settings carry the planner's cost weights, sequence count and fallback spacings (the
    defaults for the LSTM planner, which has none of them)."""
    import planners.learned.spatial_guided as guided
    from planners.search.tree import CostWeights

    def search(problem, settings, *rest):
        raise Searched(settings)

    monkeypatch.setattr(guided, "plan_guided", search)
    with pytest.raises(Searched) as searched:
        planners.make(label, **options).plan(START, HeightMap.flat(), (6.0, 0.0), P)
    settings = searched.value.args[0]
    assert settings.cost_weights == CostWeights(*weights) and settings.n_sequences == sequences
    assert settings.fallback_spacing == fallback


@pytest.mark.parametrize("label", ["step@robust", "lstm-guided@robust"])
def test_a_planar_robustness_setting_is_refused_on_a_map(label):
    """On a map the particles fly every hop at the robustness's sigmas, then at 1 sigma: a planar search's field
    (``depth`` here) would be ignored, so it is refused in one line naming it; the map search's own fields plan."""
    with pytest.raises(ValueError, match=r"depth=4 is a planar search setting") as error:
        planners.make(label, robustness={"depth": 4}).plan(START, HeightMap.flat(), (6.0, 0.0), P)
    message = str(error.value)
    assert "\n" not in message and "1 sigma" in message and "noise, sigmas, friction_loss" in message
    with pytest.raises(ValueError, match=r"lookahead=0, max_nodes=5 are planar"):
        planners.make(label, robustness={"lookahead": 0, "max_nodes": 5}).plan(START, HeightMap.flat(), (6.0, 0.0), P)
    for robustness in ({}, {"noise": "realistic*2", "sigmas": 1.5, "friction_loss": 0.02}):
        plan = planners.make(label, robustness=robustness).plan(START, HeightMap.flat(), (6.0, 0.0), P)
        assert plan.success and "robust" in plan.message, plan.message
