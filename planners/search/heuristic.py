"""The terrain-heuristic baseline (paper, section VII, after Magana et al. and Kim et al.): a nominal gait
from the apex speed, with each step moved to the nearest safe cell when it falls in a ditch or near an edge.
It never simulates while planning (zero ODE calls) and so predicts no apexes."""
from __future__ import annotations

import functools
import math

import numpy as np

from drakeslip import SlipParams, Terrain, step_batch

from planners.base import FootstepSequence, Plan, Planner, Problem
from planners.search.tree import clear_of_edges

SPEEDS = np.linspace(0.2, 5.0, 49)       # calibration grid: apex speed [m/s] ...
DROPS = np.linspace(0.55, 1.65, 45)      # ... and apex height above the landing surface [m]


@functools.cache
def neutral_gait(params: SlipParams):
    """The speed-keeping hop on flat ground, tabulated once per hopper over (speed, drop): the foothold offset
    from the apex and the apex-to-apex advance. Found by bisection on the leg angle with the fast step map
    (a one-off calibration, like a robot's gait table; plans themselves make no step-map calls)."""
    v, drop = (a.ravel() for a in np.meshgrid(SPEEDS, DROPS, indexing="ij"))
    apex = np.stack([np.zeros_like(v), drop, v], axis=1)
    terrain = Terrain.flat(0.0, x0=-5.0, length=20.0)
    free = params.with_friction(10.0)  # friction limits the plan's feasibility, not where the neutral point is
    lo, hi = np.full(v.size, -0.2), np.full(v.size, 1.2)
    for _ in range(40):  # the next apex speed falls as the leg reaches further forward
        mid = 0.5 * (lo + hi)
        res = step_batch(apex, mid, terrain, free)
        faster = np.where(res.ok, res.next_xdot > v, res.failure != 6)  # a STALL (6): the leg reached too far
        lo, hi = np.where(faster, mid, lo), np.where(faster, hi, mid)
    res = step_batch(apex, 0.5 * (lo + hi), terrain, free)
    good = res.ok & (np.abs(res.next_xdot - v) < 1e-3 * np.maximum(v, 1))
    # Where no hop keeps its speed (too high an apex bottoms out, too fast a hop trips), the gait borrows
    # the nearest entry that has one: the heuristic still proposes a step, and the simulation judges it.
    ij = np.stack(np.meshgrid(np.arange(SPEEDS.size), np.arange(DROPS.size), indexing="ij"), -1).reshape(-1, 2)
    nearest = np.flatnonzero(good)[np.argmin(((ij[:, None, :] - ij[good][None, :, :]) ** 2).sum(-1), axis=1)]
    shape = (SPEEDS.size, DROPS.size)
    return res.touchdown_x[nearest].reshape(shape), res.next_x[nearest].reshape(shape)


def interpolate(table, v: float, drop: float) -> float:
    """Bilinear interpolation in a (SPEEDS x DROPS) table, clamped to its range; NaN for a NaN input."""
    if not (math.isfinite(v) and math.isfinite(drop)):
        return math.nan
    v, drop = min(max(v, SPEEDS[0]), SPEEDS[-1]), min(max(drop, DROPS[0]), DROPS[-1])
    i = min(int(np.searchsorted(SPEEDS, v, side="right")) - 1, SPEEDS.size - 2)
    j = min(int(np.searchsorted(DROPS, drop, side="right")) - 1, DROPS.size - 2)
    a = (v - SPEEDS[i]) / (SPEEDS[i + 1] - SPEEDS[i])
    b = (drop - DROPS[j]) / (DROPS[j + 1] - DROPS[j])
    t = table[i:i + 2, j:j + 2]
    return float((1 - a) * ((1 - b) * t[0, 0] + b * t[0, 1]) + a * ((1 - b) * t[1, 0] + b * t[1, 1]))


class HeuristicPlanner(Planner):
    """Nominal gait: every hop keeps the apex speed and (absolute) height, the foot placed at the neutral
    point for the drop to the surface it lands on (see ``neutral_gait``). A foothold is safe when it is not
    in a ditch and no edge lies within ``edge_margin`` of it; an unsafe one moves to the nearest safe cell
    centre within ``max_shift`` (ties go forward), else there is no plan. The gait goes on
    from the foothold actually chosen. The controller picks the leg angles when the plan is executed, so
    the plan's ``leg_angles`` are NaN, and so are its apexes (the gait table's are not a prediction)."""

    name = "heuristic"

    def __init__(self, edge_margin: float = 0.03, max_shift: float = 0.4, **budget):
        super().__init__(**budget)
        if not (edge_margin >= 0 and max_shift >= 0):
            raise ValueError(f"edge_margin and max_shift must be non-negative, got {edge_margin}, {max_shift}")
        self.edge_margin = edge_margin
        self.max_shift = max_shift
        neutral_gait(SlipParams().with_friction(1.0))  # calibrate now, not inside the first plan's time

    def safe(self, terrain, x: np.ndarray) -> np.ndarray:
        return (terrain.height_at(x) > terrain.ditch_height) & clear_of_edges(terrain, x, self.edge_margin)

    def _plan(self, problem: Problem) -> Plan:
        apex, terrain = problem.apex, problem.terrain
        offset_table, advance_table = neutral_gait(problem.params.with_friction(1.0))
        v, z = apex.xdot, apex.z
        shifts = np.arange(1, int(round(self.max_shift / terrain.cell)) + 1) * terrain.cell
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
            if not self.safe(terrain, np.array([x]))[0]:
                # nearest safe cell centre, forward first on ties, still ahead of the previous foothold
                centre = terrain.x0 + (math.floor((x - terrain.x0) / terrain.cell) + 0.5) * terrain.cell
                options = np.concatenate([[centre], np.ravel(np.column_stack([centre + shifts, centre - shifts]))])
                options = options[(np.abs(options - x) <= self.max_shift + 1e-9) & (options < problem.window_end)
                                  & (options > (footholds[-1] if footholds else apex.x))]
                good = options[self.safe(terrain, options)]
                if good.size == 0:
                    return Plan(self.name, False, problem.target_x,
                                message=f"no plan found: no safe foothold within {self.max_shift} m of x={x:.2f}")
                moved = float(good[np.argmin(np.abs(good - x) - 1e-9 * (good > x))])
                apex_x += moved - x
                x = moved
            footholds.append(float(x))
            apex_x += interpolate(advance_table, v, z - terrain.height_at(x))
        n = len(footholds)  # the controller picks the angles and the gait table only guesses the apexes: NaN
        seq = FootstepSequence(np.array(footholds), np.full(n, np.nan), np.full((n, 3), np.nan))
        return Plan(self.name, True, problem.target_x, sequences=[seq])
