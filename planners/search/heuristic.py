"""The terrain-heuristic baseline (paper, section VII, after Magana et al. and Kim et al.): a nominal gait
from the apex speed, with each step moved to the nearest safe cell when it falls in a ditch or near an edge.
It never simulates while planning (zero ODE calls) and so predicts no apexes."""
from __future__ import annotations

import math
import time

import numpy as np

from drakeslip import SlipParams

from planners.base import FootstepSequence, Plan, Planner, Problem
from planners.search.gait import interpolate, neutral_gait
from planners.search.spatial_heuristic import plan_heuristic
from planners.search.spatial_problem import spatial_problem
from planners.search.tree import clear_of_edges

EDGE_MARGIN, MAX_SHIFT = 0.03, 0.4       # [m] the planner's defaults for the paper's hopper


class HeuristicPlanner(Planner):
    """Nominal gait: every hop keeps the apex speed and (absolute) height, the foot placed at the neutral
    point for the drop to the surface it lands on (see ``neutral_gait``). A foothold is safe when it is not
    in a ditch and no edge lies within ``edge_margin`` of it; an unsafe one moves to the nearest safe cell
    centre within ``max_shift`` (ties go forward), else there is no plan. The gait goes on
    from the foothold actually chosen. The controller picks the leg angles when the plan is executed, so
    the plan's ``leg_angles`` are NaN, and so are its apexes (the gait table's are not a prediction).
    ``edge_margin`` and ``max_shift`` [m] left at None are the paper's 3 cm and 40 cm in the hopper's lengths."""

    name = "heuristic"

    def __init__(self, edge_margin: float | None = None, max_shift: float | None = None, **budget):
        super().__init__(**budget)
        if not ((edge_margin is None or edge_margin >= 0) and (max_shift is None or max_shift >= 0)):
            raise ValueError(f"edge_margin and max_shift must be non-negative, got {edge_margin}, {max_shift}")
        self.edge_margin = edge_margin
        self.max_shift = max_shift
        neutral_gait(SlipParams().with_friction(1.0))  # calibrate now, not inside the first plan's time

    def plan_on_map(self, apex, height_map, goal, params=None) -> Plan:
        """The heuristic on a height map (``planners.search.spatial_heuristic``): Raibert's foot placement, turning
        toward the target, snapped to the nearest safe cell."""
        t0 = time.perf_counter()
        problem = spatial_problem(apex, height_map, goal, params, self.horizon, t0, self.budget.max_time_s)
        units = problem.units
        plan = plan_heuristic(problem, units.length_or(self.edge_margin, EDGE_MARGIN),
                              units.length_or(self.max_shift, MAX_SHIFT), self.name)
        plan.time_s = time.perf_counter() - t0
        return plan

    def safe(self, terrain, x: np.ndarray, edge_margin: float) -> np.ndarray:
        return (terrain.height_at(x) > terrain.ditch_height) & clear_of_edges(terrain, x, edge_margin)

    def _plan(self, problem: Problem) -> Plan:
        apex, terrain = problem.apex, problem.terrain
        offset_table, advance_table = neutral_gait(problem.params.with_friction(1.0))
        v, z = apex.xdot, apex.z
        edge_margin = problem.units.length_or(self.edge_margin, EDGE_MARGIN)
        max_shift = problem.units.length_or(self.max_shift, MAX_SHIFT)
        shifts = np.arange(1, int(round(max_shift / terrain.cell)) + 1) * terrain.cell
        footholds = []
        apex_x = apex.x
        while not footholds or footholds[-1] < problem.target_x:
            # the neutral foothold for the drop to the surface it lands on (found from the ground below first;
            # a ditch there is dealt with by moving the step, below)
            below = terrain.height_at(apex_x)
            x = apex_x + interpolate(offset_table, v, z - below)
            if math.isfinite(x) and terrain.height_at(x) > terrain.ditch_height:
                x = apex_x + interpolate(offset_table, v, z - terrain.height_at(x))
            if not math.isfinite(x):
                return Plan(self.name, False, problem.target_x, message=f"no plan found: no gait at "
                            f"{v:.2f} m/s from {z:.2f} m (x = {apex_x:.2f})")
            if x >= problem.window_end:  # the gait runs out of the perception window: plan up to its edge
                if not footholds:
                    return Plan(self.name, False, problem.target_x,
                                message=f"no plan found: the first step, to x={x:.2f}, leaves the perception window")
                break
            if not self.safe(terrain, np.array([x]), edge_margin)[0]:
                # nearest safe cell centre, forward first on ties, still ahead of the previous foothold
                centre = terrain.x0 + (math.floor((x - terrain.x0) / terrain.cell) + 0.5) * terrain.cell
                options = np.concatenate([[centre], np.ravel(np.column_stack([centre + shifts, centre - shifts]))])
                options = options[(np.abs(options - x) <= max_shift + 1e-9) & (options < problem.window_end)
                                  & (options > (footholds[-1] if footholds else apex.x))]
                good = options[self.safe(terrain, options, edge_margin)]
                if good.size == 0:
                    return Plan(self.name, False, problem.target_x,
                                message=f"no plan found: no safe foothold within {max_shift:g} m of x={x:.2f}")
                moved = float(good[np.argmin(np.abs(good - x) - 1e-9 * (good > x))])
                apex_x += moved - x
                x = moved
            footholds.append(float(x))
            apex_x += interpolate(advance_table, v, z - terrain.height_at(x))
        n = len(footholds)  # the controller picks the angles and the gait table only guesses the apexes: NaN
        seq = FootstepSequence(np.array(footholds), np.full(n, np.nan), np.full((n, 3), np.nan))
        return Plan(self.name, True, problem.target_x, sequences=[seq])
