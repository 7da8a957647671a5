"""The foothold ranker's training label: how much room a candidate first foothold leaves a hop later."""
from __future__ import annotations

import numpy as np

from planners.base import Problem
from planners.learned.ranker import ROOM_CAP, SPACING
from planners.search.step_space import StepSpacePlanner
from planners.search.tree import run_depth


class OneHopRoom:
    """The training label of candidate first footholds: the hop to each simulated on the fast step map with
    Step-space's checks; from the apex it reaches, the deepest run of working footholds on the 2.5 cm grid (how far
    the next foothold may miss and still work), ``ROOM_CAP`` past the target, -1 when the hop fails."""

    def __init__(self, controller):
        self.grid = StepSpacePlanner(controller=controller, spacing=SPACING, fallback_spacing=())

    def __call__(self, problem: Problem, x: np.ndarray, theta: np.ndarray) -> np.ndarray:
        ok, apexes = self.grid.simulate(problem, problem.apex, x, theta)
        rooms = np.full(x.size, -1.0)
        for i in np.flatnonzero(ok):
            rooms[i] = ROOM_CAP if x[i] >= problem.target_x else self._room(problem, apexes[i])
        return rooms

    def _room(self, problem: Problem, apex) -> float:
        x_l = self.grid.candidates(apex, problem.terrain, problem.params, SPACING, until=problem.window_end)
        theta = self.grid.aim(apex, x_l, problem.terrain, problem.params)
        ok, _ = self.grid.simulate(problem, apex, x_l, theta)
        if (ok & (x_l >= problem.target_x)).any():
            return ROOM_CAP
        return min(float(run_depth(ok).max(initial=0)), ROOM_CAP)
