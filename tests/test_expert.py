"""The goal-reaching expert (planners/learned/training/expert.py) and the sequences made from its rollouts."""
import numpy as np
import pytest

import drakeslip as ds
from planners.learned.training.dataset import DatasetConfig, instance, instance_sequences
from planners.learned.training.expert import GoalReachingExpert
from planners.search.tree import run_depth
from planners.learned.inputs import encode_window
from planners.search.step_space import StepSpacePlanner


def test_run_depth_counts_steps_to_the_nearest_gap():
    mask = np.array([1, 1, 1, 0, 1, 1, 1, 1, 1, 0, 1], dtype=bool)
    assert run_depth(mask).tolist() == [1, 2, 1, 0, 1, 2, 3, 2, 1, 0, 1]
    assert run_depth(np.zeros(3, dtype=bool)).tolist() == [0, 0, 0]


def test_expert_choice_hops_and_leaves_a_plan_to_the_goal():
    """The choice is goal-reaching: its hop works and Step-space plans on to the target from where it lands;
    it is at least as deep inside the goal-reaching candidates as any other."""
    terrain, params = ds.ditch_world(1003), ds.SlipParams()
    apex = ds.ApexState(0.0, 0.8, 1.5)
    expert = GoalReachingExpert()
    window = terrain.perceived(apex.x)
    label = expert.label(apex, window, 10.0, params)
    assert label.choice >= 0 and label.reaching[label.choice] and label.ode_calls > 0
    depth = run_depth(label.reaching)
    assert depth[label.choice] == depth.max()
    hop = ds.step(apex, expert.controller.leg_angle(apex, label.foothold, window), terrain, params)
    assert hop.ok and abs(hop.touchdown_x - label.foothold) < 0.02
    plan = StepSpacePlanner().plan(hop.next_apex, window, 10.0, params)
    assert plan.success


def test_look_ahead_expert_keeps_margin_and_more_room_a_hop_later():
    """With look_ahead the goal-reaching set is the same, the choice lies at least LOOK_AHEAD_MARGIN deep inside
    its run, and the state its hop reaches leaves more room than the plain choice's does (from this start the
    two choices differ)."""
    from planners.learned.training.expert import LOOK_AHEAD_MARGIN

    terrain, params = ds.ditch_world(1003), ds.SlipParams(friction=0.8)
    apex, plain = ds.ApexState(0.0, 0.7, 1.0), GoalReachingExpert()
    window = terrain.perceived(apex.x)
    base = plain.label(apex, window, 10.0, params)
    ahead = GoalReachingExpert(look_ahead=True).label(apex, window, 10.0, params)
    assert np.array_equal(ahead.reaching, base.reaching) and ahead.ode_calls > base.ode_calls
    depth = run_depth(ahead.reaching)
    assert depth[ahead.choice] >= min(LOOK_AHEAD_MARGIN, depth.max())

    def room_after(label):
        hop = ds.step(apex, plain.controller.leg_angle(apex, label.foothold, window), terrain, params)
        return run_depth(plain.label(hop.next_apex, window, 10.0, params).reaching).max()

    assert room_after(ahead) > room_after(base) >= 1


def test_expert_sequences_follow_the_rollout():
    """Every label is one of its step's goal-reaching bins, sequences move forward, and a seed fixes them."""
    cfg = DatasetConfig(planner="expert", subcells=4, min_steps=1, n_terrains=2, apexes_per_terrain=1,
                        friction=0.8, seed=4, explore=0.5)
    arrays = instance_sequences(cfg, 0)
    steps, viable = arrays["steps"], arrays["viable"]
    assert steps.shape[0] >= 2 and steps.max() < 440
    rows, cols = np.nonzero(steps >= 0)
    assert np.all(viable[rows, cols, steps[rows, cols]])
    assert not viable[steps < 0].any()
    assert all(np.all(np.diff(s[s >= 0]) > 0) for s in steps)
    _, terrain, apex = instance(cfg, 0)
    assert arrays["s0"][0] == encode_window(terrain, apex).s0_bin(4)
    again = instance_sequences(cfg, 0)
    assert np.array_equal(again["steps"], steps) and np.array_equal(again["apex"], arrays["apex"])
    with pytest.raises(ValueError, match="explore"):
        DatasetConfig(planner="expert", explore=1.5)
    with pytest.raises(ValueError, match="expert_look_ahead"):
        DatasetConfig(planner="step", expert_look_ahead=True)


def test_committed_expert_model_plans_one_hop_that_works():
    """The mode planner with the expert-trained model (one step ahead) picks, from the suites' start states on a
    ditch terrain, a first foothold whose hop works and lands where it aimed; zero step-map calls."""
    import planners

    terrain, params = ds.ditch_world(1003).perceived(-1.0), ds.SlipParams(friction=0.8)
    planner = planners.make("lstm@no-ranker")
    assert planner.model.config.hidden == 256 and planner.model.config.subcells == 4
    for apex in [(-1.0, 0.8, 1.0), (-1.0, 1.0, 2.0), (-1.0, 0.8, 3.0)]:
        plan = planner.plan(apex, terrain, 10.0, params)
        assert plan.success and plan.ode_calls == 0 and plan.footholds.size == 1
        hop = ds.step(apex, plan.leg_angles[0], terrain, params)
        assert hop.ok and abs(hop.touchdown_x - plan.footholds[0]) < 0.02


class _Policy:
    """A stand-in for a learned planner that always proposes the same offset from the apex."""

    def __init__(self, offset):
        self.offset = offset

    def plan(self, apex, terrain, goal_x, params):
        from planners.base import FootstepSequence, Plan

        x = np.array([apex.x + self.offset])
        return Plan("policy", True, goal_x, sequences=[FootstepSequence(x, np.full(1, np.nan), np.full((1, 3), np.nan))])


def test_dagger_rollout_follows_the_policy_only_where_it_reaches_the_goal():
    """With a policy the rollout hops to the policy's foothold when it is goal-reaching and to the expert's
    choice otherwise; a policy that is never goal-reaching leaves the expert's own rollout."""
    import planners

    terrain, params, apex = ds.step_world(1005), ds.SlipParams(friction=0.8), ds.ApexState(-1.0, 0.9, 1.5)
    expert = GoalReachingExpert()
    learned = planners.make("lstm@no-ranker", controller=expert.controller)
    states = expert.rollout(apex, terrain, 10.0, params, np.random.default_rng(0), policy=learned)
    labelled = [(label, x) for _, label, x in states if label.choice >= 0]
    assert len(labelled) >= 5 and all(expert.goal_reaching(label, x) for label, x in labelled)
    assert any(x != label.foothold for label, x in labelled)  # the policy was followed somewhere
    own = expert.rollout(apex, terrain, 10.0, params, np.random.default_rng(0))
    behind = expert.rollout(apex, terrain, 10.0, params, np.random.default_rng(0), policy=_Policy(-3.0))
    assert [x for *_, x in behind] == [x for *_, x in own]
    assert all(x == label.foothold for _, label, x in own if label.choice >= 0)


class _ExpertPolicy(_Policy):
    """Proposes the expert's own choice."""

    def __init__(self, expert):
        self.expert = expert

    def plan(self, apex, terrain, goal_x, params):
        self.offset = self.expert.label(apex, terrain, goal_x, params).foothold - apex.x
        return super().plan(apex, terrain, goal_x, params)


def test_the_expert_path_diagnostic_scores_each_state(example):
    """examples/lstm_diagnostics.py --diagnostics 4: a planner that proposes the expert's choice is goal-reaching
    at every state of the expert's path; one that steps behind the body never is."""
    from planners.formats.suite import Case

    diagnostics = example("lstm_diagnostics")
    expert, params = GoalReachingExpert(), ds.SlipParams(friction=0.8)
    cases = [Case("short", ds.ditch_world(1003), ds.ApexState(-1.0, 0.8, 1.5))]
    hit, width, whole, n = diagnostics.expert_path(cases, 2.0, params, _ExpertPolicy(expert), expert)
    assert (hit, whole) == (1.0, 1.0) and n >= 2 and width >= 1
    assert diagnostics.expert_path(cases, 2.0, params, _Policy(-3.0), expert)[::2] == (0.0, 0.0)


def test_the_top_k_oracle_is_the_mode_planner_at_k_1_and_picks_a_goal_reaching_foothold(example):
    """examples/lstm_diagnostics.py --diagnostics 5: with k = 1 the oracle plans the one-step mode planner's
    foothold; with k = 8 a goal-reaching one, leaving at least as much room a hop later as the mode does."""
    from planners import make
    from planners.checkpoints import EXPERT_WEIGHTS

    diagnostics = example("lstm_diagnostics")
    params, apex = ds.SlipParams(friction=0.8), ds.ApexState(0.0, 0.7, 1.0)
    window = ds.ditch_world(1003).perceived(apex.x)
    mode = float(make("lstm@no-ranker").plan(apex, window, 10.0, params).footholds[0])
    one = diagnostics.TopKOracle(1, model=EXPERT_WEIGHTS).plan(apex, window, 10.0, params)
    assert one.footholds.tolist() == [mode]

    oracle = diagnostics.TopKOracle(8, model=EXPERT_WEIGHTS)
    pick = float(oracle.plan(apex, window, 10.0, params).footholds[0])
    label, apexes, target_x = oracle.expert.candidates(apex, window, 10.0, params)

    def room(x):
        return oracle.expert.room(label, oracle.expert.candidate_index(label, x), apexes, target_x, window, 10.0,
                                  params)

    assert oracle.expert.goal_reaching(label, pick)
    assert not oracle.expert.goal_reaching(label, mode) or room(pick) >= room(mode)


def test_a_similar_hoppers_data_are_the_papers_in_its_units():
    """Data for a hopper 1.4 times as long-legged with the paper's k L0 / (m g): its instances are the paper's
    scaled (Froude speeds), and its encoded windows, starts and Step-space labels are the paper's: for it the
    committed models are what training would make."""
    similar = {"mass": 7.0 * 1.4 ** 3, "leg_length": 0.7, "stiffness": 3200.0 * 1.4 ** 2}
    paper = DatasetConfig(planner="step", subcells=4, min_steps=1, n_terrains=1, apexes_per_terrain=1,
                          friction=0.8, seed=4, goal_sequences=2, max_nodes=200)
    mine = DatasetConfig(**{**paper.__dict__, "hopper": similar})
    (_, t_paper, a_paper), (_, t_mine, a_mine) = instance(paper, 0), instance(mine, 0)
    assert t_mine.cell == pytest.approx(1.4 * t_paper.cell) and a_mine.x == pytest.approx(1.4 * a_paper.x)
    assert a_mine.xdot == pytest.approx(a_paper.xdot * 1.4 ** 0.5)
    assert a_mine.z - t_mine.height_at(a_mine.x) == pytest.approx(1.4 * (a_paper.z - t_paper.height_at(a_paper.x)))
    ours, theirs = instance_sequences(mine, 0), instance_sequences(paper, 0)
    np.testing.assert_allclose(ours["terrain"], theirs["terrain"], atol=1e-5)
    np.testing.assert_allclose(ours["apex"], theirs["apex"], atol=1e-5)
    assert np.array_equal(ours["steps"], theirs["steps"]) and np.array_equal(ours["s0"], theirs["s0"])
    with pytest.raises(ValueError, match="hopper"):
        DatasetConfig(hopper={"mass": 1.0, "legs": 2})
