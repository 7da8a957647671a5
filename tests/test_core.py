"""The compiled planning core (planners/core) against what it compiles: the model against torch, the controller
against StepLengthController, and its searches against the Python best-first search, node for node."""
import copy
import math
import time

import numpy as np
import pytest
import torch

from drakeslip import SlipParams, StepLengthController, Terrain
from drakeslip.fast_controller import aim_rows
from planners.checkpoints import SUBCELL_WEIGHTS
from planners.core.model import encode, first_gates, first_step_logits, model_arrays
from planners.formats.suite import load_suite
from planners.learned.inputs import encode_window
from planners.learned.lstm import FootstepDistribution, load_model
from planners.registry import make

SUITE = load_suite("suites/step.json")
PARAMS = SlipParams(friction=SUITE.friction)
CASES = SUITE.cases[::37][:4]


@pytest.mark.parametrize("apex", [(1.234, 1.1, 2.0), (3.02, 0.8, 1.0), (5.5, 1.4, 3.0)])
def test_compiled_model_matches_torch(apex):
    """The first step's logits from a node's apex, window and bin under the body: within 1e-6 of torch's forward
    pass on the same weights (float64; the shipped float32 model agrees to float32's precision)."""
    from drakeslip import ApexState

    model = load_model(SUBCELL_WEIGHTS)
    net = FootstepDistribution(model)
    enc = encode_window(SUITE.cases[3].terrain, ApexState(*apex))
    terrain, apex_in, s0, _ = net.inputs(enc)
    arrays = model_arrays(model)
    code = encode(terrain[0], enc.s0_bin(net.subcells), arrays)
    logits = first_step_logits(apex_in[0], first_gates(code, arrays), arrays, np.empty(0, np.int64))
    with torch.no_grad():   # copies: the loaded model is shared by every planner in the process
        double, _ = copy.deepcopy(model).double()(torch.tensor(terrain), torch.tensor(apex_in), torch.tensor(s0)[:, None])
        single, _ = model(torch.tensor(terrain).float(), torch.tensor(apex_in).float(),
                                  torch.tensor(s0).float()[:, None])
    assert np.abs(logits - double[0, 0].numpy()).max() < 1e-6
    assert np.abs(logits - single[0, 0].numpy()).max() < 1e-3 * max(1.0, np.abs(logits).max())


def test_the_compiled_tanh_is_within_3e_16_of_libms():
    from planners.core.model import tanh

    tiny = np.geomspace(1e-300, 1.0, 601)
    x = np.concatenate((np.linspace(-30.0, 30.0, 20001), tiny, -tiny, [0.0, 1e3, -1e3, 1e300]))
    mine = np.array([tanh(v) for v in x])
    assert np.abs(mine - np.array([math.tanh(v) for v in x])).max() <= 3e-16
    assert math.copysign(1.0, tanh(-0.0)) == -1.0 and tanh(-1e300) == -1.0


def test_the_logits_of_a_few_bins_are_those_of_every_bin():
    model = load_model(SUBCELL_WEIGHTS)
    arrays = model_arrays(model)
    rng = np.random.default_rng(3)
    for _ in range(5):
        gates = first_gates(encode(rng.uniform(-1, 1, 110), int(rng.integers(0, 440)), arrays), arrays)
        apex = rng.uniform([0.5, 0.2, 0.0], [3.0, 1.5, 1.0])
        bins = np.sort(rng.choice(440, 30, replace=False))
        every = first_step_logits(apex, gates, arrays, np.empty(0, np.int64))
        few = first_step_logits(apex, gates, arrays, bins)
        np.testing.assert_allclose(few[bins], every[bins], rtol=0, atol=1e-12)
        assert np.all(np.delete(few, bins) == -np.inf)


def numpy_network(net, apexes, footholds, grounds):
    """The controller's network in numpy (``x @ w + b``, ``np.tanh``), before the polish."""
    w_in, b_in, w_hidden, b_hidden, w_head, b_head, mean, std, scale, max_angle = net[:10]
    feats = np.stack([apexes[:, 2], apexes[:, 1] - grounds, footholds - apexes[:, 0]], axis=1)
    x = np.tanh(((feats / scale - mean) / std) @ w_in + b_in)
    for w, b in zip(w_hidden, b_hidden):
        x = np.tanh(x @ w + b)
    return np.clip((x @ w_head[:, None] + b_head)[:, 0] * max_angle, -max_angle, max_angle)


def test_compiled_controller_is_the_network_in_numpy_to_the_bit():
    """``aim_rows`` (what ``leg_angles`` returns and the core aims with) against the network computed by numpy,
    for batches of every size the searches use, and for another hopper (scaled features)."""
    rng = np.random.default_rng(0)
    for params in (PARAMS, SlipParams(leg_length=0.8, mass=20.0, stiffness=6000.0)):
        controller = StepLengthController.load_default().for_params(params)
        net = controller.arrays()
        for n in (1, 2, 5, 17, 40, 300):
            apexes = np.stack([rng.uniform(-1, 5, n), rng.uniform(0.6, 1.5, n), rng.uniform(0.3, 3.5, n)], axis=1)
            footholds = apexes[:, 0] + rng.uniform(-0.3, 1.2, n)
            grounds = rng.uniform(-0.2, 0.2, n)
            assert np.array_equal(aim_rows(apexes, footholds, grounds, net._replace(refine=False)),
                                  numpy_network(net, apexes, footholds, grounds))
        expected = controller.leg_angles(apexes, footholds, Terrain.flat())
        assert np.array_equal(aim_rows(apexes, footholds, np.zeros(n), net), expected)


def same_search(a, b):
    """The same tree, node for node (the root's angle and foothold are NaN)."""
    ta, tb = a.tree, b.tree
    return (ta.parent == tb.parent and ta.foothold[1:] == tb.foothold[1:] and ta.angle[1:] == tb.angle[1:]
            and ta.apex == tb.apex and ta.cost == tb.cost and ta.goals == tb.goals and ta.expanded == tb.expanded
            and (a.ode_calls, a.nodes_expanded, a.stop) == (b.ode_calls, b.nodes_expanded, b.stop))


@pytest.mark.parametrize("label", ["step", "step@robust"])
def test_compiled_grid_search_makes_the_python_searchs_tree(label):
    """The one search loop compiled with the compiled grid expansion, and run as Python with the expansion the Drake
    step map's search uses (its candidates flown here on the fast step map, one Python call a node)."""
    planner = make(label)
    for case in CASES:
        problem = planner.problem(case.apex, case.terrain, SUITE.goal_x, PARAMS, time.perf_counter())
        robust, spacing = planner.attempt_settings(problem.units)[0]
        assert same_search(planner.python_search(problem, spacing, robust),
                           planner._search(problem, spacing, robust)), case.id


@pytest.mark.parametrize("label", ["lstm-guided", "lstm-guided@robust"])
def test_compiled_sampled_search_makes_the_python_searchs_tree(label):
    planner = make(label)
    for case in CASES:
        problem = planner.problem(case.apex, case.terrain, SUITE.goal_x, PARAMS, time.perf_counter())
        robust = planner.robustness_levels()[0]
        assert same_search(planner.python_search(problem, planner.attempts[0], robust),
                           planner._search(problem, planner.attempts[0], robust)), case.id


def test_a_core_plan_says_where_its_time_went():
    case = CASES[0]
    for label in ("step", "lstm-guided"):
        plan = make(label).plan(case.apex, case.terrain, SUITE.goal_x, PARAMS)
        parts = plan.timing
        assert set(parts) == {"step_map_s", "controller_s", "model_s", "search_s"}
        assert all(v >= 0 for v in parts.values()) and parts["step_map_s"] > 0 and parts["controller_s"] > 0
        assert (parts["model_s"] > 0) == (label == "lstm-guided")
        assert sum(parts.values()) == pytest.approx(plan.time_s, rel=1e-9, abs=1e-12)


def test_a_node_whose_candidates_all_lie_in_ditches_has_no_children():
    """Over a ditch wider than a hop, every candidate's bin is masked: no draw, no child, in both searches."""
    heights = np.zeros(200)
    heights[35:80] = -1.0   # a ditch from x = 0.5 to 5 m
    terrain = Terrain(heights, 0.1, -3.0)
    planner = make("lstm-guided")
    problem = planner.problem((2.0, 1.5, 1.0), terrain, 10.0, PARAMS, time.perf_counter())
    core = planner._search(problem, planner.attempts[0])
    python = planner.python_search(problem, planner.attempts[0])
    assert len(core.tree) == 1 and core.ode_calls == 0 and same_search(python, core)


def test_planning_speed_script_prints_the_ratios(run_script):
    code, out, _ = run_script("planning_speed", "--suites", "suites/ditch.json", "--planners", "step,lstm-guided",
                              "--pairs", "step:lstm-guided", "--cases", "2", "--repeats", "1")
    assert code == 0 and "mean t_plan step / lstm-guided = " in out and "controller ms" in out and " nodes " in out
    code, _, err = run_script("planning_speed", "--pairs", "step:angle")
    assert code == 2 and "--pairs names labels not in --planners: angle" in err and len(err.strip().splitlines()) == 1
