"""How good is the footstep model as a guide for planning? Five diagnostics (docs/results.md, "The learned
planners on fresh suites" and "DAgger"):

    python3 examples/lstm_diagnostics.py --suite out/fresh/ditch-8000.json --every 3 --weights planners/weights/lstm.pt

1. First step: from each case's start, of the model's probability on the admissible candidate footholds
   (Step-space's grid after its checks that need no simulation), the share on footholds that work (the hop
   succeeds on the fast step map and keeps Step-space's minimum speed), and how often the most probable works.
2. Search: of the candidates each planner simulates, the share that work (Step-space's grid; LSTM-guided,
   lazy, conditioned on the path or on each node's apex), over one plan from each start.
3. Greedy oracle, a diagnostic and not a planner: at every step take the most probable foothold that really
   works from the true apex (checked on the fast step map), in the receding-horizon protocol on the fast
   backend. Its success rate bounds any planner that follows the model's mode without lookahead.
4. Expert's path (``--diagnostics 4``, slow: the expert searches from every candidate): along the goal-reaching
   expert's rollout from each start (planners/expert.py), how often the one-step mode planner's foothold is
   goal-reaching, how wide the goal-reaching sets are, and in how many cases it is goal-reaching at every state.
   A mode planner must be right at each of a case's hops, so this per-hop rate is what its success compounds.
   With ``--look-ahead`` the path is the look-ahead expert's (the foothold leaving the most room a hop later).
5. Top-k oracle (``--diagnostics 5 --top-k 1,2,3``, slow like 4): the one-step mode planner in the receding-
   horizon protocol on the fast backend, except that of its k most probable first footholds it takes the
   goal-reaching one that leaves the most room a hop later (the look-ahead expert's criterion), and its mode
   when none is goal-reaching. k = 1 is the mode planner itself. Its success bounds what a learned re-ranker
   of the model's k best footholds (a value or feasibility head) could add to the mode planner.
"""
from __future__ import annotations

import argparse
import math
from collections import Counter
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from drakeslip import ApexState, SlipParams  # noqa: E402
from planners import make  # noqa: E402
from planners.base import FootstepSequence, Plan  # noqa: E402
from planners.evaluation import EvalConfig, perceived, run_case  # noqa: E402
from planners.expert import GoalReachingExpert  # noqa: E402
from planners.foothold_ranker import top_candidates  # noqa: E402
from planners.lstm_guided import LSTMGuidedPlanner, PathConditionedSampler  # noqa: E402
from planners.lstm_inference import softmax  # noqa: E402
from planners.lstm_inputs import encode_window  # noqa: E402
from planners.lstm_planner import LSTMPlanner  # noqa: E402
from planners.search import SearchTree  # noqa: E402
from planners.step_space import StepSpacePlanner  # noqa: E402
from planners.suite import load_suite  # noqa: E402


class Counting:
    """Mixin for Step-space planners: counts the candidates simulated and those that became children."""

    tried = worked = 0

    def simulate(self, problem, apex, x_l, theta):
        ok, apexes = super().simulate(problem, apex, x_l, theta)
        self.tried += int(np.count_nonzero(~np.isnan(theta)))
        self.worked += int(np.count_nonzero(ok))
        return ok, apexes


class GreedyOracle(LSTMPlanner):
    """The most probable working foothold at every step, found by simulating (so not zero-ODE: a bound)."""

    def __init__(self, **options):
        super().__init__(**options)
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


class TopKOracle(LSTMPlanner):
    """Diagnostic 5: the one-step mode planner whose pick among its ``k`` most probable first footholds is made by
    the expert (simulates and searches: a bound, not a planner)."""

    def __init__(self, k: int, expert: GoalReachingExpert | None = None, **options):
        super().__init__(max_steps=1, **options)
        self.k = k
        self.expert = expert or GoalReachingExpert(controller=self.controller)

    def _ranked(self, problem, grid, score, theta):
        top = top_candidates(score, self.k)
        if top.size < 2:
            return score
        label, apexes, target_x = self.expert.candidates(problem.apex, problem.terrain, problem.goal_x, problem.params)
        room = {}
        for i in top:
            j = self.expert.candidate_index(label, grid[i])
            if j >= 0 and label.reaching[j]:
                room[i] = self.expert.room(label, j, apexes, target_x, problem.terrain, problem.goal_x,
                                           problem.params)
        pick = max(room, key=room.get) if room else top[0]  # max keeps the more probable of equal rooms
        return np.where(np.arange(score.size) == pick, score, 0.0)


def crossed(planner, cases, goal_x, params):
    """(share of ``cases`` ``planner`` crosses in the receding-horizon protocol on the fast backend, its failures
    by kind): diagnostics 3 and 5."""
    results = [run_case(planner, planner.controller, case, goal_x, params, EvalConfig(backend="fast")) for case in cases]
    failures = Counter(r["failure"] for r in results if not r["success"])
    return float(np.mean([r["success"] for r in results])), dict(failures)


def first_step(cases, goal_x, params, weights):
    """(share of admissible probability on working footholds, share of starts whose mode works)."""
    guided, grid = make("lstm-guided", weights=weights), make("step")
    shares, modes = [], []
    for case in cases:
        problem = guided.problem(case.apex, perceived(case.terrain, case.apex.x), goal_x, params, 0.0)
        x_l = grid.candidates(case.apex, problem.terrain, params, None, problem.window_end)
        theta = grid.aim(case.apex, x_l, problem.terrain, params)
        ok, _ = grid.simulate(problem, case.apex, x_l, theta)
        p = PathConditionedSampler(guided.net, problem, 1.0).weights(SearchTree(tuple(case.apex)), 0, x_l)
        p = np.where(np.isnan(theta), 0.0, p)
        if p.sum() > 0:
            shares.append(p[ok].sum() / p.sum())
            modes.append(bool(ok[np.argmax(p)]))
    return float(np.mean(shares)), float(np.mean(modes))


def search(cases, goal_x, params, weights):
    """Diagnostic 2, printed per planner."""
    print("2. search: share of simulated candidates that work (one plan from each start)")
    counted = {"Step-space": type("CountingStep", (Counting, StepSpacePlanner), {})(),
               "LSTM-guided, lazy, path": type("CountingGuided", (Counting, LSTMGuidedPlanner), {})(
                   weights=weights, lazy=True),
               "LSTM-guided, lazy, apex": type("CountingGuided", (Counting, LSTMGuidedPlanner), {})(
                   weights=weights, lazy=True, conditioning="apex")}
    for label, planner in counted.items():
        for case in cases:
            planner.plan(case.apex, perceived(case.terrain, case.apex.x), goal_x, params)
        print(f"   {label:<26} {100 * planner.worked / max(planner.tried, 1):5.1f} % of {planner.tried}")


def expert_path(cases, goal_x, params, planner, expert=None):
    """(share of the expert's states where ``planner``'s first foothold is goal-reaching, median goal-reaching
    set width in candidates, share of cases where it is goal-reaching at every state, states)."""
    expert = expert or GoalReachingExpert()
    hits, widths, whole = [], [], []
    for case in cases:
        mine = []
        for apex, label, _ in expert.rollout(case.apex, case.terrain, goal_x, params, np.random.default_rng(0)):
            if label.choice >= 0:
                plan = planner.plan(apex, perceived(case.terrain, apex.x), goal_x, params)
                mine.append(plan.success and expert.goal_reaching(label, plan.footholds[0]))
                widths.append(int(label.reaching.sum()))
        hits += mine
        whole.append(bool(mine) and all(mine))  # a start the expert has no way on from counts as missed
    return float(np.mean(hits)), float(np.median(widths)), float(np.mean(whole)), len(hits)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--suite", required=True, help="suite JSON file (format drakeslip-suite/1)")
    ap.add_argument("--weights", default=None, help="footstep model (default: the committed Table I model)")
    ap.add_argument("--every", type=int, default=3, help="take every K-th case")
    ap.add_argument("--diagnostics", default="1,2,3", help="which diagnostics to run, comma-separated (1-5)")
    ap.add_argument("--look-ahead", action="store_true",
                    help="diagnostic 4 follows the look-ahead expert (GoalReachingExpert(look_ahead=True))")
    ap.add_argument("--top-k", default="1,2,3", help="diagnostic 5: the k values, comma-separated")
    args = ap.parse_args(argv)
    if args.every < 1:
        ap.error(f"--every must be at least 1, got {args.every}")
    chosen = set(args.diagnostics.split(","))
    if not chosen <= {"1", "2", "3", "4", "5"}:
        ap.error(f"--diagnostics takes numbers 1-5, got {args.diagnostics!r}")
    try:
        top_k = [int(k) for k in args.top_k.split(",")]
    except ValueError:
        top_k = []
    if not top_k or min(top_k) < 1:
        ap.error(f"--top-k takes positive integers, comma-separated, got {args.top_k!r}")
    try:
        suite = load_suite(args.suite)
    except (OSError, ValueError) as error:  # a missing or malformed suite file
        ap.error(str(error))
    cases = suite.cases[::args.every]
    params = SlipParams(friction=suite.friction)
    print(f"{suite.name}: {len(cases)} cases, model {args.weights or 'planners/weights/lstm.pt'}")

    if "1" in chosen:
        share, mode = first_step(cases, suite.goal_x, params, args.weights)
        print(f"1. first step: {100 * share:.1f} % of the admissible probability on working footholds; "
              f"the mode works from {100 * mode:.1f} % of the starts")
    if "2" in chosen:
        search(cases, suite.goal_x, params, args.weights)
    if "3" in chosen:
        success, failures = crossed(GreedyOracle(weights=args.weights), cases, suite.goal_x, params)
        print(f"3. greedy oracle: {100 * success:.1f} % reach the goal; failures {failures}")
    if "4" in chosen:
        mode = make("lstm", weights=args.weights, max_steps=1)
        expert = GoalReachingExpert(look_ahead=args.look_ahead)
        hit, width, whole, n = expert_path(cases, suite.goal_x, params, mode, expert)
        print(f"4. expert's path: the one-step mode planner's foothold is goal-reaching in {100 * hit:.1f} % of "
              f"{n} states (goal-reaching sets: median {width:g} candidates of 2.5 cm); at every state of "
              f"{100 * whole:.1f} % of the cases")
    if "5" in chosen:
        for k in top_k:
            success, failures = crossed(TopKOracle(k, weights=args.weights), cases, suite.goal_x, params)
            print(f"5. top-{k} oracle: {100 * success:.1f} % reach the goal; failures {failures}")


if __name__ == "__main__":
    main()
