"""Planning for any hopper: every label plans for a hopper unlike the paper's on a suite drawn for it, and its plans
execute; for the paper's hopper the encodings, grids and settings are the unscaled ones to the bit; a hopper similar
to the paper's on the paper's terrain scaled to it reads the paper's encoding; a terrain on other cells is
resampled onto the model's."""
import math

import numpy as np
import pytest

import planners
from drakeslip import ApexState, SlipParams, Terrain, ditch_world, mixed_world
from drakeslip.controller import StepLengthController
from drakeslip.hopper_file import NamedHopper
from drakeslip.rollout import rollout
from drakeslip.terrain_file import scaled_terrain
from drakeslip.units import HopperUnits, units_of
from planners.base import Problem
from planners.closed_loop import ClosedLoopConfig, run_case
from planners.formats.suite_draw import draw_suite
from planners.learned.inputs import encode_window, reference_height
from planners.learned.ranker import candidate_features
from planners.registry import labels, make_planners, planner_name

BIG = NamedHopper(SlipParams(mass=12.0, leg_length=0.7, stiffness=6000.0), "big")   # k L0 / (m g) = 35.7


@pytest.fixture(scope="module")
def controller():
    return StepLengthController.load_default()


@pytest.fixture(scope="module")
def big_case():
    suite = draw_suite("ditch", 7000, BIG, n_terrains=1, speeds=(2.0,), heights=(0.9,))
    return suite, suite.cases[0], BIG.params.with_friction(suite.friction)


@pytest.mark.parametrize("label", labels())
def test_every_label_plans_for_another_hopper_and_its_plan_executes(controller, big_case, label):
    """On the hopper's perception window (11 m x 1.4), each label plans footholds on solid ground; the controller
    lands the hopper on them on the fast step map, every hop of the first three completing, except for the
    planners that do not simulate (the heuristic and the paper's mode planner: their first foothold is reached).
    Trajectory optimization plans to a goal three hops ahead (a whole window takes it half a minute)."""
    suite, case, params = big_case
    units = units_of(params)
    window = case.terrain.perceived(case.apex.x, *units.window)
    assert window.x_end - window.x0 == pytest.approx(11.0 * units.length)
    goal = case.apex.x + 2.0 * units.length if planner_name(label) == "trajopt" else suite.goal_x
    plan = make_planners({label: None}, controller)[label].plan(case.apex, window, goal, params)
    assert plan.success, plan.message
    assert np.all(window.height_at(plan.footholds) > window.ditch_height)
    assert plan.footholds[0] > case.apex.x - params.leg_length and plan.footholds[-1] < window.x_end
    executed = plan.footholds[:3]
    run = rollout(case.apex, case.terrain, params, footholds=executed, controller=controller, backend="fast")
    assert run.footholds[0] == pytest.approx(executed[0], abs=1e-6)
    if label not in ("heuristic", "lstm@paper"):
        assert run.ok, (run.failure, run.failed_hop)
        assert run.footholds == pytest.approx(list(executed), abs=1e-6)


@pytest.mark.parametrize("label", ["step", "lstm-guided", "step@robust"])
def test_another_hopper_crosses_a_drawn_ditch_suite_case_in_the_loop(controller, big_case, label):
    suite, case, params = big_case
    planner = make_planners({label: None}, controller)[label]
    result = run_case(planner, controller, case, suite.goal_x, params, ClosedLoopConfig(backend="fast"))
    assert result["success"], result["failure"]
    assert result["final_x"] >= suite.goal_x > case.apex.x + 10.0   # the course is longer than the paper's 11 m


@pytest.mark.slow
@pytest.mark.parametrize("label", ["step", "lstm-guided"])
def test_another_hopper_crosses_a_drawn_ditch_suite_case_on_drake(controller, big_case, label):
    suite, case, params = big_case
    planner = make_planners({label: None}, controller)[label]
    result = run_case(planner, controller, case, suite.goal_x, params, ClosedLoopConfig(backend="drake"))
    assert result["success"], result["failure"]


def unscaled_encoding(terrain: Terrain, apex: ApexState):
    """The footstep model's inputs as the paper's hopper's encoding defines them: 110 cells of the terrain's own
    10 cm, heights relative to the ground in metres, the apex in metres and m/s."""
    heights, x_start = terrain.window(apex.x, 8.0, 3.0)
    s0 = int(round(3.0 / terrain.cell))
    ditch = heights <= terrain.ditch_height
    ground = reference_height(heights, s0, ditch)
    offset = (apex.x - terrain.x0) / terrain.cell - math.floor((apex.x - terrain.x0) / terrain.cell)
    return (np.clip(heights - ground, -1.0, 1.0).astype(np.float32),
            np.array([apex.z - ground, apex.xdot, offset], dtype=np.float32), s0, x_start, ditch)


PAPER_TERRAINS = [ditch_world(1003), mixed_world(3004), mixed_world(3011)]   # mixed: levels below and above 0


@pytest.mark.parametrize("terrain", PAPER_TERRAINS, ids=["ditch", "mixed", "mixed-low"])
def test_the_paper_hoppers_encoding_is_the_unscaled_one_to_the_bit(terrain):
    for x in np.linspace(-1.0, 12.0, 27):
        apex = ApexState(x, terrain.height_at(x) + 0.9 if not terrain.is_ditch_at(x) else 1.0, 2.1)
        enc = encode_window(terrain, apex)
        heights, apex_in, s0, x_start, ditch = unscaled_encoding(terrain, apex)
        assert enc.terrain.tobytes() == heights.tobytes() and enc.apex.tobytes() == apex_in.tobytes()
        assert (enc.s0, enc.x_start, enc.cell) == (s0, x_start, terrain.cell)
        np.testing.assert_array_equal(enc.ditch, ditch)
        assert encode_window(terrain, apex, units_of(SlipParams(mass=3.0, friction=0.6))).terrain.tobytes() \
            == heights.tobytes()   # mass and friction are no length or speed


def test_the_paper_hoppers_settings_and_ranker_features_are_the_unscaled_ones():
    units = units_of(SlipParams())
    assert (units.length, units.speed, units.time, units.window) == (1.0, 1.0, 1.0, (8.0, 3.0))
    terrain, apex = PAPER_TERRAINS[1], ApexState(0.4, 1.2, 1.7)
    step = planners.make("step")
    assert step.spacings(units) == (0.025, 0.01) and 0.025 == terrain.cell / 4
    problem = step.problem(apex, terrain.perceived(apex.x), 30.0, None, 0.0)
    assert (problem.window_end, problem.target_x) == (apex.x + 8.0, apex.x + 7.0)
    x = np.linspace(0.6, 2.5, 9)
    features = candidate_features(problem, x, np.linspace(-1, -3, 9), np.linspace(0.1, 0.3, 9))
    ground, window = problem.terrain.height_at(x), problem.terrain
    around = x[:, None] + (np.arange(-5, 30) + 0.5) * window.cell
    expected = np.column_stack([apex.z - ground, np.full(9, apex.xdot), x - apex.x,
                                np.clip(ground - window.height_at(apex.x), -1, 1), np.linspace(0.1, 0.3, 9),
                                np.linspace(-1, -3, 9), np.arange(9), np.mod((x - window.x0) / window.cell, 1.0),
                                np.clip(window.height_at(around) - ground[:, None], -1, 1)]).astype(np.float32)
    assert features.tobytes() == expected.tobytes()


@pytest.mark.parametrize("terrain, length", [(PAPER_TERRAINS[0], 0.6), (PAPER_TERRAINS[0], 2.4),
                                             (PAPER_TERRAINS[1], 1.4), (PAPER_TERRAINS[2], 2.4)])
def test_a_similar_hopper_on_the_scaled_terrain_reads_the_papers_encoding(terrain, length):
    """Scaled lengths, Froude-scaled speeds: the encoding is the paper's up to rounding, ditch floors included
    (a scaled terrain keeps its ditches at -1 m, which the encoding takes at least as deep as -1 m x length)."""
    hopper = SlipParams(mass=7.0 * length ** 3, leg_length=0.5 * length, stiffness=3200.0 * length ** 2)
    units = units_of(hopper)
    assert units.length == pytest.approx(length) and units.stiffness == pytest.approx(units_of(SlipParams()).stiffness)
    big = scaled_terrain(terrain, length)
    for x in np.linspace(-1.0, 12.0, 15) + 0.0137:   # off the cell edges, where rounding picks either cell
        apex = ApexState(x, terrain.height_at(x) + 0.9 if not terrain.is_ditch_at(x) else 1.0, 2.1)
        mine = encode_window(big, ApexState(x * length, apex.z * length, apex.xdot * units.speed), units)
        paper = encode_window(terrain, apex)
        np.testing.assert_allclose(mine.terrain, paper.terrain, atol=1e-5)
        np.testing.assert_allclose(mine.apex, paper.apex, atol=1e-5)
        np.testing.assert_array_equal(mine.ditch, paper.ditch)
        assert mine.s0 == paper.s0 and mine.cell == pytest.approx(paper.cell * length)


def test_a_terrain_on_other_cells_is_resampled_onto_the_models():
    """The paper's ditch world on 2 cm cells reads as on its own 10 cm cells; on 3 cm cells a model cell any ditch
    reaches into is a ditch, and a solid one takes the highest height under it."""
    coarse = ditch_world(1003)
    fine = Terrain(np.repeat(coarse.heights, 5), 0.02, coarse.x0)
    for x in (-0.95, 0.33, 4.07):
        apex = ApexState(x, 1.0, 2.0)
        a, b = encode_window(coarse, apex), encode_window(fine, apex)
        np.testing.assert_array_equal(a.terrain, b.terrain)
        assert a.x_start == pytest.approx(b.x_start)
        np.testing.assert_array_equal(a.ditch, b.ditch)
        assert b.cell == pytest.approx(0.1) and b.apex == pytest.approx(a.apex, abs=1e-6)
    odd = Terrain(np.r_[np.zeros(38), [0.05, 0.0, 0.0, -1.0], np.zeros(60)], 0.03, -1.0)   # a 3 cm ditch at 0.23
    enc = encode_window(odd, ApexState(0.0, 0.9, 1.0))
    centres = enc.x_of_bin(np.arange(enc.terrain.size))
    ditch = centres[enc.ditch]
    assert enc.terrain.size == 110 and ditch.size == 1 and abs(ditch[0] - 0.25) <= 0.05
    before = np.flatnonzero(enc.ditch)[0] - 1
    assert enc.terrain[before] == pytest.approx(0.05)   # 0.1-0.2 holds the 5 cm cell at 0.14: the highest


def test_planner_options_given_are_si_and_left_at_none_are_the_hoppers(big_case):
    suite, case, params = big_case
    units = units_of(params)
    default, given = planners.make("step"), planners.make("step", spacing=0.025, edge_margin=0.02)
    assert default.spacings(units) == pytest.approx((0.025 * 1.4, 0.01 * 1.4)) and given.spacings(units)[0] == 0.025
    window = case.terrain.perceived(case.apex.x, *units.window)
    problem: Problem = default.problem(case.apex, window, suite.goal_x, params, 0.0)
    assert problem.units == units and problem.window_end == pytest.approx(min(case.apex.x + 8.0 * 1.4,
                                                                              window.known_end))
    assert problem.target_x == pytest.approx(problem.window_end - 1.4)
    short = planners.make("step", horizon=1.2)
    with pytest.raises(ValueError, match="target margin, 1.4 m for this hopper"):
        short.plan(case.apex, window, suite.goal_x, params)
    assert short.plan(case.apex, window, suite.goal_x, SlipParams(leg_length=0.3)).target_x == pytest.approx(
        case.apex.x + 1.2 - 0.6)
    assert HopperUnits.of(params).length_or(None, 0.02) == pytest.approx(0.028)
