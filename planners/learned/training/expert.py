"""The goal-reaching expert whose rollouts train the footstep model for the mode planner.

A search tree's root-to-leaf paths (the paper's data) label each step with one of many footholds that happened
to work; the mode of a model fit to them lands anywhere in, or between, the bands of working footholds, and
a hop later the hopper is often in a state with no way on. The expert labels a state with the foothold that
keeps the most room for error on the way to the goal instead:

- its candidates are a grid of desired footholds (the sub-cell model's bins), aimed by the controller and
  simulated with Step-space's checks (one batched fast step-map call);
- a candidate is *goal-reaching* when its hop works and Step-space finds a plan from the apex it reaches to
  the target (the goal, or the end of what the robot sees);
- the label is the goal-reaching candidate deepest inside its run of goal-reaching neighbours (ties: the
  farthest), so a foothold missed by a few centimetres still leaves a way on;
- with ``look_ahead``, the label is instead, of the candidates at least ``LOOK_AHEAD_MARGIN`` deep inside
  their run, the one whose next state has the most room (the deepest run of goal-reaching candidates one hop
  later, as seen from here): a learner that misses by a bin or two is then in states where the band it must
  hit is wide.

A model trained on the expert's own rollouts sees only the states the expert visits; ``rollout(policy=...)``
follows a trained planner instead (DAgger), so the next round of data holds the states the model gets itself
into, each with the expert's label.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from drakeslip import ApexState, SlipParams, StepLengthController, Terrain
from drakeslip.rollout import rollout
from drakeslip.units import units_of

from planners.search.step_space import StepSpacePlanner
from planners.search.tree import run_depth

LOOK_AHEAD_MARGIN = 2  # least run depth of a look-ahead label: a goal-reaching neighbour on either side


@dataclass
class ExpertLabel:
    """The expert's view of one state: the candidate footholds ``x_l``, which of them are goal-reaching, and
    the index of its choice (-1 when none is)."""

    x_l: np.ndarray
    reaching: np.ndarray
    choice: int
    ode_calls: int

    @property
    def foothold(self) -> float:
        return float(self.x_l[self.choice])


class GoalReachingExpert:
    """Labels states (see the module doc). ``spacing`` is the candidate grid; ``max_nodes`` bounds each
    Step-space search from a candidate's apex (a search that runs out counts as not goal-reaching). The
    searches that reach the goal expand a few dozen nodes, and the node budget, unlike a time budget, gives
    the same labels on any machine; ``max_time_s`` is only a safety net."""

    def __init__(self, spacing: float = 0.025, controller: StepLengthController | None = None,
                 max_nodes: int = 300, max_time_s: float = 600.0, look_ahead: bool = False):
        self.spacing = float(spacing)
        self.look_ahead = bool(look_ahead)
        self.controller = controller or StepLengthController.load_default()
        self.grid = StepSpacePlanner(controller=self.controller, spacing=self.spacing, fallback_spacing=())
        self.search = StepSpacePlanner(controller=self.controller, max_nodes=max_nodes, max_time_s=max_time_s)

    def label(self, apex, terrain: Terrain, goal_x: float, params: SlipParams) -> ExpertLabel:
        label, apexes, target_x = self.candidates(apex, terrain, goal_x, params)
        if label.choice < 0 or not self.look_ahead:
            return label
        depth = run_depth(label.reaching)
        room = {i: self.room(label, i, apexes, target_x, terrain, goal_x, params)
                for i in np.flatnonzero(depth >= min(LOOK_AHEAD_MARGIN, depth.max()))}
        label.choice = int(max(room, key=lambda i: (room[i], depth[i], i)))
        return label

    def room(self, label: ExpertLabel, i: int, apexes, target_x: float, terrain: Terrain, goal_x: float,
             params: SlipParams) -> float:
        """How much room candidate ``i`` of ``label`` (from ``candidates``) leaves a hop later: the deepest run of
        goal-reaching candidates from the apex it reaches, infinite past the target (nothing left to keep room
        for). Its step-map calls are added to ``label.ode_calls``."""
        if label.x_l[i] >= target_x:
            return np.inf
        after = self.candidates(apexes[i], terrain, goal_x, params)[0]
        label.ode_calls += after.ode_calls
        return float(run_depth(after.reaching).max(initial=0))

    def candidates(self, apex, terrain: Terrain, goal_x: float, params: SlipParams):
        """The plain label (no look-ahead), each candidate's next apex and the target x."""
        problem = self.grid.problem(apex, terrain, goal_x, params, time.perf_counter())
        x_l = self.grid.candidates(problem.apex, terrain, params, self.spacing, until=problem.window_end)
        theta = self.grid.aim(problem.apex, x_l, terrain, params)
        ok, apexes = self.grid.simulate(problem, problem.apex, x_l, theta)
        calls = int(np.count_nonzero(~np.isnan(theta)))
        reaching = ok & (x_l >= problem.target_x)
        for i in np.flatnonzero(ok & ~reaching):
            result = self.search.search(apexes[i], terrain, goal_x, params)
            calls += result.ode_calls
            reaching[i] = bool(result.tree.goals)
        if not reaching.any():
            return ExpertLabel(x_l, reaching, -1, calls), apexes, problem.target_x
        depth = run_depth(reaching)
        label = ExpertLabel(x_l, reaching, int(np.flatnonzero(depth == depth.max())[-1]), calls)
        return label, apexes, problem.target_x

    def candidate_index(self, label: ExpertLabel, x: float) -> int:
        """The index of ``label``'s candidate at foothold ``x`` (within half a grid step), -1 if none is."""
        j = int(np.abs(label.x_l - x).argmin())
        return j if abs(label.x_l[j] - x) < self.spacing / 2 else -1

    def goal_reaching(self, label: ExpertLabel, x: float) -> bool:
        """Whether foothold ``x`` is one of ``label``'s goal-reaching candidates."""
        j = self.candidate_index(label, x)
        return j >= 0 and bool(label.reaching[j])

    def rollout(self, apex: ApexState, terrain: Terrain, goal_x: float, params: SlipParams,
                rng: np.random.Generator, explore: float = 0.0, max_hops: int = 40, policy=None) -> list:
        """States from ``apex`` to the goal, each hop to the expert's choice or, with probability ``explore``,
        to a random goal-reaching candidate (so the data covers states next to the expert's path). With a
        ``policy`` (a planner, e.g. the one-step LSTM mode planner) a hop that does not explore goes to the
        policy's first foothold when that is goal-reaching and to the expert's choice when it is not: the
        states are then the ones the learned planner visits, labelled by the expert also where the planner
        would go wrong (DAgger, Ross et al. 2011). Returns [(apex, label, executed foothold)], ending at the
        goal, a state with no goal-reaching candidate (its label has choice -1) or a failed hop."""
        states = []
        for _ in range(max_hops):
            window = terrain.perceived(apex.x, *units_of(params).window)
            label = self.label(apex, window, goal_x, params)
            if label.choice < 0:
                states.append((apex, label, float("nan")))
                break
            x = label.foothold
            if rng.random() < explore:
                x = float(rng.choice(label.x_l[label.reaching]))
            elif policy is not None:
                mine = policy.plan(apex, window, goal_x, params)
                if mine.success and self.goal_reaching(label, mine.footholds[0]):
                    x = float(mine.footholds[0])
            states.append((apex, label, x))
            hop = rollout(apex, terrain, params, footholds=[x], controller=self.controller, backend="fast")
            if hop.failure is not None:
                break
            apex = ApexState(*map(float, hop.apexes[-1]))
            if apex.x >= goal_x:
                break
        return states
