"""How good is the footstep model as a guide for planning? Five diagnostics (docs/learned.md):

    python3 examples/lstm_diagnostics.py --suite suites/ditch.json --every 15 --cases 10 \\
        --model planners/weights/lstm_paper.pt

The model diagnosed is --model (default: the paper's, planners/weights/lstm_paper.pt), in every planner below.

1. First step: from each case's start, of the model's probability on the admissible candidate footholds
   (Step-space's grid after its checks that need no simulation), the share on footholds that work (the hop
   succeeds on the fast step map and keeps Step-space's minimum speed), and how often the most probable works.
2. Search: of the candidates each planner simulates, the share that work (Step-space's grid; LSTM-guided,
   lazy, conditioned on the path or on each node's apex), over one plan from each start.
3. Greedy oracle, a diagnostic and not a planner: at every step take the most probable foothold that really
   works from the true apex (checked on the fast step map), in the receding-horizon protocol on the fast
   backend. Its success rate bounds any planner that follows the model's mode without lookahead.
4. Expert's path (``--diagnostics 4``, slow: the expert searches from every candidate): along the goal-reaching
   expert's rollout from each start
   (planners/learned/training/expert.py), how often the one-step mode planner's foothold is
   goal-reaching, how wide the goal-reaching sets are, and in how many cases it is goal-reaching at every state.
   A mode planner must be right at each of a case's hops, so this per-hop rate is what its success compounds.
   With ``--look-ahead`` the path is the look-ahead expert's (the foothold leaving the most room a hop later).
5. Top-k oracle (``--diagnostics 5 --top-k 1,2,3``, slow like 4): the one-step mode planner in the receding-
   horizon protocol on the fast backend, except that of its k most probable first footholds it takes the
   goal-reaching one that leaves the most room a hop later (the look-ahead expert's criterion), and its mode
   when none is goal-reaching. k = 1 is the mode planner itself. Its success bounds what a learned re-ranker
   of the model's k best footholds (a value or feasibility head) could add to the mode planner.

The "one-step mode planner" is the LSTM planner one step ahead without a re-ranker (planners.make("lstm",
model=..., max_steps=1, ranker=None)); the greedy oracle plans up to 12 steps, as the paper's planner does.

Exit status: 0 when the diagnostics ran, 2 for a usage or input error (a missing or malformed suite, a damaged
model file).
"""
from __future__ import annotations

import argparse
import math
import os
import sys
from collections import Counter

from drakeslip.jobs import cli  # before numpy: a Ctrl-C while it loads is one line (drakeslip/jobs/cli.py)

import numpy as np

from drakeslip import ApexState, SlipParams
from planners.checkpoints import PAPER_WEIGHTS

DIAGNOSTICS = ("1", "2", "3", "4", "5")
GREEDY_STEPS = 12  # the greedy oracle's plan length: the paper's LSTM planner's


class Counting:
    """Mixin for Step-space planners: counts the candidates simulated and those that work, in the search run as Python
    (whose expansions call ``simulate``; the compiled search makes the same trees without calling it)."""

    tried = worked = 0

    def _search(self, problem, setting, robust=None):
        return self.python_search(problem, setting, robust)

    def simulate(self, problem, apex, x_l, theta):
        ok, apexes = super().simulate(problem, apex, x_l, theta)
        self.tried += int(np.count_nonzero(~np.isnan(theta)))
        self.worked += int(np.count_nonzero(ok))
        return ok, apexes


def _oracles() -> dict:
    """The oracles, LSTMPlanner subclasses: defined on first use, so that ``--help`` imports no torch."""
    return {"GreedyOracle": _greedy_oracle(), "TopKOracle": _top_k_oracle()}


def _greedy_oracle() -> type:
    """The greedy oracle's class (diagnostic 3)."""
    from planners.base import FootstepSequence, Plan
    from planners.learned.inference import softmax
    from planners.learned.inputs import encode_window
    from planners.learned.lstm import LSTMPlanner
    from planners.search.step_space import StepSpacePlanner

    class GreedyOracle(LSTMPlanner):
        """The most probable working foothold at every step, for up to ``max_steps`` steps, found by simulating
        (so not zero-ODE: a bound)."""

        def __init__(self, max_steps: int = GREEDY_STEPS, ranker=None, **options):
            super().__init__(max_steps=max_steps, ranker=ranker, **options)
            self.checker = StepSpacePlanner(controller=self.controller)  # its candidates, checks and simulation

        def _plan(self, problem):
            terrain, params, checker = problem.terrain, problem.params, self.checker
            enc = encode_window(terrain, problem.apex)
            window, apex_in, prev, mask = self.net.inputs(enc)
            state = self.net.model.initial_state(apex_in)
            apex, footholds, behind = problem.apex, [], -math.inf
            for _ in range(self.max_steps):
                logits, state = self.net.model.step(window, prev, state)
                p = softmax(logits, mask)[0]
                x_l = checker.candidates(apex, terrain, params, None, problem.window_end)
                x_l = x_l[x_l > behind]
                theta = checker.aim(apex, x_l, terrain, params)
                ok, apexes = checker.simulate(problem, apex, x_l, theta)
                bins = self.net.bin_of(enc, x_l)
                score = np.where(ok & (bins >= 0) & (bins < p.size), p[np.clip(bins, 0, p.size - 1)], 0.0)
                if not score.any():
                    break
                best = int(np.argmax(score))
                footholds.append(behind := float(x_l[best]))
                apex = ApexState(*apexes[best])
                if behind >= problem.target_x:
                    break
                prev = np.zeros_like(prev)
                prev[0, self.net.bin_of(enc, behind)] = 1.0
            if not footholds:
                return Plan(self.name, False, problem.target_x, message="no foothold works from here: a dead end")
            f = np.array(footholds)
            return Plan(self.name, True, problem.target_x,
                        sequences=[FootstepSequence(f, np.full(f.size, np.nan), np.full((f.size, 3), np.nan))])

    return GreedyOracle


def _top_k_oracle() -> type:
    """The top-k oracle's class (diagnostic 5)."""
    from planners.learned.lstm import LSTMPlanner
    from planners.learned.ranker import top_candidates
    from planners.learned.training.expert import GoalReachingExpert

    class TopKOracle(LSTMPlanner):
        """Diagnostic 5: the one-step mode planner whose pick among its ``k`` most probable first footholds is
        made by the expert (simulates and searches: a bound, not a planner)."""

        def __init__(self, k: int, expert: GoalReachingExpert | None = None, ranker=None, **options):
            super().__init__(max_steps=1, ranker=ranker, **options)
            self.k = k
            self.expert = expert or GoalReachingExpert(controller=self.controller)

        def pick_first(self, problem, grid, score, theta):
            top = top_candidates(score, self.k)
            if top.size < 2:
                return score
            label, apexes, target_x = self.expert.candidates(problem.apex, problem.terrain, problem.goal_x,
                                                             problem.params)
            room = {}
            for i in top:
                j = self.expert.candidate_index(label, grid[i])
                if j >= 0 and label.reaching[j]:
                    room[i] = self.expert.room(label, j, apexes, target_x, problem.terrain, problem.goal_x,
                                               problem.params)
            pick = max(room, key=room.get) if room else top[0]  # max keeps the more probable of equal rooms
            return np.where(np.arange(score.size) == pick, score, 0.0)

    return TopKOracle


def __getattr__(name: str):
    """``GreedyOracle`` and ``TopKOracle``, defined when first asked for (e.g. by the tests)."""
    if name in ("GreedyOracle", "TopKOracle"):
        oracles = _oracles()
        globals().update(oracles)
        return oracles[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def crossed(planner, cases, goal_x, params):
    """(share of ``cases`` ``planner`` crosses in the receding-horizon protocol on the fast backend, its failures
    by kind): diagnostics 3 and 5."""
    from planners.closed_loop import ClosedLoopConfig, run_case

    config = ClosedLoopConfig(backend="fast")
    results = [run_case(planner, planner.controller, case, goal_x, params, config) for case in cases]
    failures = Counter(r["failure"] for r in results if not r["success"])
    return float(np.mean([r["success"] for r in results])), dict(failures)


def first_step(cases, goal_x, params, model):
    """(share of admissible probability on working footholds, share of starts whose mode works)."""
    from planners import make
    from planners.learned.lstm_guided import PathConditionedSampler
    from planners.search.tree import SearchTree

    guided, grid = make("lstm-guided", model=model), make("step")
    shares, modes = [], []
    for case in cases:
        problem = guided.problem(case.apex, case.terrain.perceived(case.apex.x), goal_x, params, 0.0)
        x_l = grid.candidates(case.apex, problem.terrain, params, None, problem.window_end)
        theta = grid.aim(case.apex, x_l, problem.terrain, params)
        ok, _ = grid.simulate(problem, case.apex, x_l, theta)
        p = PathConditionedSampler(guided.net, problem, 1.0).probabilities(SearchTree(tuple(case.apex)), 0, x_l)
        p = np.where(np.isnan(theta), 0.0, p)
        if p.sum() > 0:
            shares.append(p[ok].sum() / p.sum())
            modes.append(bool(ok[np.argmax(p)]))
    return float(np.mean(shares)), float(np.mean(modes))


def search(cases, goal_x, params, model):
    """Diagnostic 2, printed per planner."""
    from planners.learned.lstm_guided import LSTMGuidedPlanner
    from planners.search.step_space import StepSpacePlanner

    print("2. search: share of simulated candidates that work (one plan from each start)")
    counted = {"Step-space": type("CountingStep", (Counting, StepSpacePlanner), {})(),
               "LSTM-guided, lazy, path": type("CountingGuided", (Counting, LSTMGuidedPlanner), {})(
                   model=model, lazy=True, conditioning="path"),
               "LSTM-guided, lazy, apex": type("CountingGuided", (Counting, LSTMGuidedPlanner), {})(
                   model=model, lazy=True, conditioning="apex")}
    for label, planner in counted.items():
        planner.tried = planner.worked = 0   # not the core's warm-up on a flat terrain when it was built
        for case in cases:
            planner.plan(case.apex, case.terrain.perceived(case.apex.x), goal_x, params)
        print(f"   {label:<26} {100 * planner.worked / max(planner.tried, 1):5.1f} % of {planner.tried}")


def expert_path(cases, goal_x, params, planner, expert=None):
    """(share of the expert's states where ``planner``'s first foothold is goal-reaching, median goal-reaching
    set width in candidates, share of cases where it is goal-reaching at every state, states)."""
    from planners.learned.training.expert import GoalReachingExpert

    expert = expert or GoalReachingExpert()
    hits, widths, whole = [], [], []
    for case in cases:
        mine = []
        for apex, label, _ in expert.rollout(case.apex, case.terrain, goal_x, params, np.random.default_rng(0)):
            if label.choice >= 0:
                plan = planner.plan(apex, case.terrain.perceived(apex.x), goal_x, params)
                mine.append(plan.success and expert.goal_reaching(label, plan.footholds[0]))
                widths.append(int(label.reaching.sum()))
        hits += mine
        whole.append(bool(mine) and all(mine))  # a start the expert has no way on from counts as missed
    return float(np.mean(hits)), float(np.median(widths)), float(np.mean(whole)), len(hits)


def diagnostic_numbers(text: str) -> set:
    """An argument type: diagnostics by number, comma-separated, from 1-5."""
    chosen = set(cli.names(text))
    if not chosen <= set(DIAGNOSTICS):
        raise argparse.ArgumentTypeError(f"takes numbers {DIAGNOSTICS[0]}-{DIAGNOSTICS[-1]}, comma-separated, "
                                         f"got {text!r}")
    return chosen


def k_values(text: str) -> list:
    """An argument type: positive integers, comma-separated."""
    return [cli.positive_int(k) for k in cli.names(text)]


def shown(path) -> str:
    """``path`` relative to the working folder when it lies inside it."""
    relative = os.path.relpath(path)
    return str(path) if relative.startswith("..") else relative


def main(argv=None) -> int:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--suite", type=cli.input_file, required=True, help="suite file (format drakeslip-suite/1)")
    ap.add_argument("--model", type=cli.input_file, default=PAPER_WEIGHTS,
                    help="the footstep model diagnosed, in every diagnostic (the paper's Table I model by default)")
    ap.add_argument("--every", type=cli.positive_int, default=3, help="take every K-th case")
    ap.add_argument("--cases", type=cli.positive_int, default=None,
                    help="only the first N cases after --every (none: all)")
    ap.add_argument("--diagnostics", type=diagnostic_numbers, default="1,2,3",
                    help="which diagnostics to run, comma-separated (1-5)")
    ap.add_argument("--look-ahead", action="store_true",
                    help="diagnostic 4 follows the look-ahead expert (GoalReachingExpert(look_ahead=True))")
    ap.add_argument("--top-k", type=k_values, default="1,2,3", help="diagnostic 5: the k values, comma-separated")
    args = ap.parse_args(argv)

    from planners.formats.suite import load_suite
    from planners.learned.lstm import load_model

    try:
        suite = load_suite(args.suite)
    except (OSError, ValueError) as error:  # a malformed suite file
        ap.error(str(error))
    try:
        load_model(args.model)
    except (OSError, ValueError) as error:  # a damaged or mismatched model file
        ap.error(f"--model: {error}")
    cases = suite.cases[::args.every][:args.cases]
    params = SlipParams(friction=suite.friction)
    chosen = args.diagnostics
    print(f"{suite.name}: {len(cases)} cases, model {shown(args.model)}")

    if "1" in chosen:
        share, mode = first_step(cases, suite.goal_x, params, args.model)
        print(f"1. first step: {100 * share:.1f} % of the admissible probability on working footholds; "
              f"the mode works from {100 * mode:.1f} % of the starts")
    if "2" in chosen:
        search(cases, suite.goal_x, params, args.model)
    if "3" in chosen:
        greedy = _greedy_oracle()(model=args.model)
        success, failures = crossed(greedy, cases, suite.goal_x, params)
        print(f"3. greedy oracle: {100 * success:.1f} % reach the goal; failures {failures}")
    if "4" in chosen:
        from planners import make
        from planners.learned.training.expert import GoalReachingExpert

        mode = make("lstm", model=args.model, max_steps=1, ranker=None)  # the one-step mode planner
        expert = GoalReachingExpert(look_ahead=args.look_ahead)
        hit, width, whole, n = expert_path(cases, suite.goal_x, params, mode, expert)
        print(f"4. expert's path: the one-step mode planner's foothold is goal-reaching in {100 * hit:.1f} % of "
              f"{n} states (goal-reaching sets: median {width:g} candidates of 2.5 cm); at every state of "
              f"{100 * whole:.1f} % of the cases")
    if "5" in chosen:
        oracle = _top_k_oracle()
        for k in args.top_k:
            success, failures = crossed(oracle(k, model=args.model), cases, suite.goal_x, params)
            print(f"5. top-{k} oracle: {100 * success:.1f} % reach the goal; failures {failures}")
    return cli.OK


if __name__ == "__main__":
    sys.exit(main())
