"""The trajectory optimization's margin-maximizing objective (planners/trajopt/margins.py): off by default with no
trace in the program, and with a positive weight it raises the solved plan's least spring travel or friction margin
(and the plan still verifies on Drake)."""
import numpy as np
import pytest

from drakeslip import SlipParams, Terrain
from planners.registry import make
from planners.trajopt.config import ObjectiveWeights, TrajoptConfig
from planners.trajopt.guess import build_guess
from planners.trajopt.margins import knot_margins
from planners.trajopt.planner import make_problem
from planners.trajopt.program import SlipTrajopt
from planners.trajopt.seeds import seed_footholds
from planners.trajopt.segments import assign_segments
from planners.trajopt.solve import verify

PARAMS = SlipParams()


@pytest.fixture(scope="module")
def flat():
    """A 3-hop cold-start problem on flat ground (each solve takes ~1-2 s), its footholds and segments."""
    problem = make_problem((0.0, 0.9, 1.5), Terrain.flat(), 2.0, PARAMS)
    footholds, _ = seed_footholds("cold", problem, TrajoptConfig.max_hops, None, 0, None)
    segs = assign_segments(problem.terrain, footholds, TrajoptConfig().for_hopper(problem.units).edge_margin,
                           problem.window_end)
    return problem, footholds, segs


def program_for(flat, objective: ObjectiveWeights):
    problem, footholds, segs = flat
    config = TrajoptConfig(objective=objective)
    program = SlipTrajopt(problem.apex, problem.terrain, segs, PARAMS, problem.target_x, config)
    guess = build_guess(problem.apex, footholds, segs, problem.terrain, PARAMS, config.node_times())
    return program, guess


def solved(flat, objective: ObjectiveWeights):
    """The solution's least margins over the knots, and whether its leg angles verify on Drake."""
    program, guess = program_for(flat, objective)
    result = program.solve(guess)
    assert result.converged, result.status
    problem = flat[0]
    check = verify(problem.apex, result.leg_angles, problem.terrain, PARAMS, problem.target_x)
    for name, var in program.margins.items():  # the max-min variable is the plan's least margin at the optimum
        assert result.x[program.prog.FindDecisionVariableIndex(var)] == pytest.approx(
            knot_margins(program, result.x)[name], abs=1e-6)
    return knot_margins(program, result.x), check["verified"]


@pytest.fixture(scope="module")
def default_margins(flat):
    return solved(flat, ObjectiveWeights())


def test_default_weights_add_no_margin_terms(flat):
    """Margin weights of 0 (the default) add no variable, constraint group or cost: N hops have exactly the leg
    angle, fall time, foothold, duration, K+1 stance states and next apex each."""
    program, guess = program_for(flat, ObjectiveWeights())
    N, K = program.N, program.K
    assert program.margins == {}
    assert program.prog.num_vars() == N * (4 + 4 * (K + 1) + 3)
    assert not {"stroke_margin", "friction_margin"} & set(program.groups)
    robust, _ = program_for(flat, ObjectiveWeights(stroke=1.0, friction=1.0))
    assert robust.prog.num_vars() == program.prog.num_vars() + 2
    assert len(robust.prog.GetAllCosts()) == len(program.prog.GetAllCosts()) + 2
    # the margin variables start at the guess's own margins (at least 0, their lower bound)
    x = robust.guess_vector(guess)
    assert np.array_equal(np.delete(x, [robust.prog.FindDecisionVariableIndex(v) for v in robust.margins.values()]),
                          program.guess_vector(guess))
    for name, var in robust.margins.items():
        assert x[robust.prog.FindDecisionVariableIndex(var)] == max(knot_margins(robust, x)[name], 0.0)


def test_a_stroke_weight_leaves_more_spring_travel(flat, default_margins):
    base, base_ok = default_margins
    margins, ok = solved(flat, ObjectiveWeights(stroke=10.0))
    assert base_ok and ok
    assert margins["stroke"] > base["stroke"] + 0.003  # ~39 -> ~45 mm


def test_a_friction_weight_leaves_more_friction_to_spare(flat, default_margins):
    base, _ = default_margins
    margins, ok = solved(flat, ObjectiveWeights(friction=10.0))
    assert ok
    assert margins["friction"] > base["friction"] + 0.01  # ~0.569 -> ~0.587


def test_the_robust_preset_carries_margin_weights():
    """``trajopt@robust`` gives its config as JSON-ready fields; the planner turns them into a TrajoptConfig."""
    planner = make("trajopt@robust")
    assert planner.config.objective.stroke > 0 and planner.config.objective.friction > 0
    assert planner.config.objective.edge == ObjectiveWeights().edge
    with pytest.raises(TypeError):
        make("trajopt", config={"objective": {"margin": 1.0}})
