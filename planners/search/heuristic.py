"""The terrain-heuristic baseline (paper, section VII, after Magana et al. and Kim et al.): a nominal gait
from the apex speed, with each step moved to the nearest safe cell when it falls in a ditch or near an edge.
It never simulates while planning (zero ODE calls) and so predicts no apexes."""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from drakeslip import SlipParams, Terrain, step_batch
from drakeslip.units import units_of

from planners.base import FootstepSequence, Plan, Planner, Problem
from planners.search.tree import clear_of_edges

# The paper's hopper's calibration grid (another hopper's is this in its units, see planners.base.Planner):
SPEEDS = np.linspace(0.2, 5.0, 49)       # apex speed [m/s] ...
DROPS = np.linspace(0.55, 1.65, 45)      # ... and apex height above the landing surface [m]
EDGE_MARGIN, MAX_SHIFT = 0.03, 0.4       # [m] the planner's defaults for the paper's hopper


@dataclass(frozen=True)
class GaitTable:
    """Values of the neutral gait tabulated over apex ``speeds`` [m/s] x ``drops`` [m] (``interpolate`` reads it)."""

    speeds: np.ndarray
    drops: np.ndarray
    values: np.ndarray   # (speeds, drops)


@functools.cache
def neutral_gait(params: SlipParams):
    """The speed-keeping hop on flat ground, tabulated once per hopper over (speed, drop) (the paper's grid in the
    hopper's units): GaitTables of the foothold offset from the apex and of the apex-to-apex advance. Found by
    bisection on the leg angle with the fast step map (a one-off calibration, like a robot's gait table; plans
    themselves make no step-map calls)."""
    units = units_of(params)
    speeds, drops = SPEEDS * units.speed, DROPS * units.length
    v, drop = (a.ravel() for a in np.meshgrid(speeds, drops, indexing="ij"))
    apex = np.stack([np.zeros_like(v), drop, v], axis=1)
    terrain = Terrain.flat(0.0, x0=-5.0 * units.length, length=20.0 * units.length)
    free = params.with_friction(10.0)  # friction limits the plan's feasibility, not where the neutral point is
    lo, hi = np.full(v.size, -0.2), np.full(v.size, 1.2)
    for _ in range(40):  # the next apex speed falls as the leg reaches further forward
        mid = 0.5 * (lo + hi)
        res = step_batch(apex, mid, terrain, free)
        faster = np.where(res.ok, res.next_xdot > v, res.failure != 6)  # a STALL (6): the leg reached too far
        lo, hi = np.where(faster, mid, lo), np.where(faster, hi, mid)
    res = step_batch(apex, 0.5 * (lo + hi), terrain, free)
    good = res.ok & (np.abs(res.next_xdot - v) < 1e-3 * np.maximum(v, units.speed))
    # Where no hop keeps its speed (too high an apex bottoms out, too fast a hop trips), the gait borrows
    # the nearest entry that has one: the heuristic still proposes a step, and the simulation judges it.
    ij = np.stack(np.meshgrid(np.arange(SPEEDS.size), np.arange(DROPS.size), indexing="ij"), -1).reshape(-1, 2)
    nearest = np.flatnonzero(good)[np.argmin(((ij[:, None, :] - ij[good][None, :, :]) ** 2).sum(-1), axis=1)]
    shape = (SPEEDS.size, DROPS.size)
    return (GaitTable(speeds, drops, res.touchdown_x[nearest].reshape(shape)),
            GaitTable(speeds, drops, res.next_x[nearest].reshape(shape)))


def interpolate(table: GaitTable, v: float, drop: float) -> float:
    """Bilinear interpolation in a gait table, clamped to its range; NaN for a NaN input."""
    if not (math.isfinite(v) and math.isfinite(drop)):
        return math.nan
    speeds, drops = table.speeds, table.drops
    v, drop = min(max(v, speeds[0]), speeds[-1]), min(max(drop, drops[0]), drops[-1])
    i = min(int(np.searchsorted(speeds, v, side="right")) - 1, speeds.size - 2)
    j = min(int(np.searchsorted(drops, drop, side="right")) - 1, drops.size - 2)
    a = (v - speeds[i]) / (speeds[i + 1] - speeds[i])
    b = (drop - drops[j]) / (drops[j + 1] - drops[j])
    t = table.values[i:i + 2, j:j + 2]
    return float((1 - a) * ((1 - b) * t[0, 0] + b * t[0, 1]) + a * ((1 - b) * t[1, 0] + b * t[1, 1]))


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
