"""pytest-benchmark: one plan of each planner on a ditch terrain from the committed suite's kind, and one
training step of the footstep model. Timing only: that every label plans this query is checked in
tests/test_planners.py, that a training step lowers the loss in tests/test_lstm.py."""
import pytest

from drakeslip import ApexState, SlipParams, ditch_world
from planners.registry import labels, make_planners, planner_name

TERRAIN = ditch_world(1003).perceived(0.0)
APEX = (0.0, 0.9, 2.0)
PARAMS = SlipParams(friction=0.8)


@pytest.fixture(scope="module")
def controller():
    from drakeslip.controller import StepLengthController
    return StepLengthController.load_default()


@pytest.mark.parametrize("label", [label for label in labels() if planner_name(label) != "trajopt"])  # trajopt: test_trajopt
def test_bench_one_plan(benchmark, controller, label):
    """Every planner name and preset, the paper's (@paper) beside the defaults."""
    planner = make_planners({label: None}, controller)[label]
    plan = benchmark.pedantic(planner.plan, args=(APEX, TERRAIN, 10.0, PARAMS),
                              rounds=5 if label != "heuristic" else 50, warmup_rounds=1)
    benchmark.extra_info.update(success=plan.success, ode_calls=plan.ode_calls, nodes_expanded=plan.nodes_expanded,
                                footholds=len(plan.footholds), timing=plan.timing)


@pytest.mark.parametrize("label", ["heuristic", "step", "step@robust", "lstm", "lstm-guided", "lstm-guided@robust"])
def test_bench_one_plan_on_a_height_map(benchmark, controller, label):
    """Each label that plans on height maps, one plan over a stairs map's 8 m window toward a goal 10 m ahead."""
    from drakeslip.spatial.families import height_map_family

    start = (-1.0, 0.0, 0.9, 1.5, 0.0)
    window = height_map_family("stairs")(58999, 0.5).perceived(-1.0, 0.0, (1.0, 0.0), 8.0, 2.0, 3.0)
    planner = make_planners({label: None}, controller)[label]
    plan = benchmark.pedantic(planner.plan, args=(start, window, (10.0, 0.0), PARAMS), rounds=5, warmup_rounds=1)
    benchmark.extra_info.update(success=plan.success, ode_calls=plan.ode_calls, nodes_expanded=plan.nodes_expanded,
                                footholds=len(plan.footholds), timing=plan.timing)


def test_bench_one_training_step(benchmark):
    """One optimizer step of the footstep model on a batch of 256 sequences of 12 steps (the real loss path,
    with the share of sequences fed the model's own distributions)."""
    import torch

    from planners.learned.model import FootstepModel
    from planners.learned.training.train_lstm import batch_loss

    torch.manual_seed(0)
    model = FootstepModel()
    opt = torch.optim.AdamW(model.parameters(), lr=1e-3)
    n = model.config.n_cells
    batch = {"terrain": torch.rand(256, n) - 0.5, "apex": torch.rand(256, 3), "s0": torch.full((256,), 30),
             "steps": torch.randint(31, n, (256, 12))}

    def step():
        loss = batch_loss(model, batch, own_inputs=0.3)[0]
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        return loss.item()

    benchmark.pedantic(step, rounds=3, warmup_rounds=1)


@pytest.mark.parametrize("n", [4, 40])
def test_bench_controller_call(benchmark, controller, n):
    """One controller call aiming n candidate footholds (with its Newton polish): LSTM-guided aims a few per
    call, Step-space a node's whole grid; the fixed cost per call is what sets their planning times."""
    import numpy as np

    benchmark(controller.leg_angles, APEX, np.linspace(0.3, 1.2, n), TERRAIN)


@pytest.mark.parametrize("n", [1, 4, 40])
def test_bench_compiled_controller_call(benchmark, controller, n):
    """The compiled controller (``aim_rows``, what the planning core calls) aiming n footholds from one apex, called
    from Python (its dispatch is in the time): a sampled search aims 4 at a time, Step-space a node's grid."""
    import numpy as np

    from drakeslip.fast_controller import aim_rows

    footholds = np.linspace(0.3, 1.2, n)
    apexes = np.tile(np.asarray(APEX, dtype=float), (n, 1))
    benchmark(aim_rows, apexes, footholds, np.asarray(TERRAIN.height_at(footholds), dtype=float),
              controller.arrays())


@pytest.mark.parametrize("part", ["new window", "node"])
def test_bench_compiled_model(benchmark, part):
    """The compiled footstep model's work in a sampled search (planners/core/model.py), called from Python: a window
    and bin under the body not seen before in the search (its CNN encoding and first-layer input gates), and every
    node (the first step's logits of 40 candidate bins from the node's apex)."""
    import numpy as np

    from planners.checkpoints import SUBCELL_WEIGHTS
    from planners.core.model import encode, first_gates, first_step_logits, model_arrays
    from planners.learned.lstm import load_model

    arrays = model_arrays(load_model(SUBCELL_WEIGHTS))
    window = np.random.default_rng(0).uniform(-0.3, 0.3, 110)
    gates = first_gates(encode(window, 120, arrays), arrays)
    if part == "new window":
        benchmark(lambda: first_gates(encode(window, 120, arrays), arrays))
    else:
        benchmark(first_step_logits, np.array([1.2, 0.6, 0.4]), gates, arrays, np.arange(130, 170))


def test_bench_lstm_step(benchmark):
    """One step of the footstep model in numpy (what LSTM-guided pays per node it expands)."""
    from planners.learned.inputs import encode_window
    from planners.learned.lstm import FootstepDistribution, load_model

    net = FootstepDistribution(load_model())  # the paper's model
    terrain, apex, s0, _ = net.inputs(encode_window(TERRAIN, ApexState(*APEX)))
    benchmark(net.model.step, terrain, s0, net.model.initial_state(apex))


@pytest.mark.parametrize("label", ["step", "lstm-guided@paper", "lstm-guided"])
def test_bench_one_plan_on_the_drake_step_map(benchmark, controller, label):
    """The same plan with every candidate hop simulated on Drake (``step_map="drake"``), where a plan's time is
    its ODE calls as for the paper's planners. One round each: a Step-space plan takes tens of seconds."""
    planner = make_planners({label: {"step_map": "drake", "max_time_s": 300}}, controller)[label]
    plan = benchmark.pedantic(planner.plan, args=(APEX, TERRAIN, 10.0, PARAMS), rounds=1, iterations=1)
    benchmark.extra_info.update(success=plan.success, ode_calls=plan.ode_calls, nodes_expanded=plan.nodes_expanded,
                                seconds_per_ode_call=benchmark.stats.stats.mean / max(plan.ode_calls, 1))
