"""The neutral gait of a hopper: the speed-keeping hop on flat ground, tabulated once per hopper over apex speed and
height (a robot's gait table). The terrain heuristics (``planners.search.heuristic`` on a profile,
``planners.search.spatial_heuristic`` on a height map) place their feet with it."""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from drakeslip import SlipParams, Terrain, step_batch
from drakeslip.units import units_of

# The paper's hopper's calibration grid (another hopper's is this in its units, see planners.base.Planner):
SPEEDS = np.linspace(0.2, 5.0, 49)       # apex speed [m/s] ...
DROPS = np.linspace(0.55, 1.65, 45)      # ... and apex height above the landing surface [m]


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
