"""Encoding of the perception window and footholds for the footstep model (shared by the dataset generator,
training and the LSTM planners).

The model reads the window in its hopper's units (``drakeslip.units.HopperUnits``): 110 cells of 10 cm times the
hopper's length factor (8 and 3 of the paper's metres ahead of and behind the body), heights relative to the ground
under the body over the length factor, the apex height over the length factor and its speed over the speed
factor. A hopper similar to the paper's (the same dimensionless stiffness, friction and stroke) on the paper's
terrains scaled to it (``drakeslip.terrain_file.scaled_terrain``) gives the paper's encoding, so the trained
models transfer; for the paper's hopper every factor is 1.0 and the encoding is the one the models were trained
on, to the bit. A terrain whose cells are not the model's is resampled onto the model's cells: a model cell is a
ditch when any ditch cell reaches into it, else it takes the highest height over it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drakeslip import ApexState, Terrain
from drakeslip.terrain import DITCH_HEIGHT
from drakeslip.units import PAPER, HopperUnits, units_of

HEIGHT_FLOOR = -1.0  # encoded heights are clipped to [HEIGHT_FLOOR, 1]; a ditch-world ditch (1 m deep) sits on it
MODEL_CELL = 0.1     # [m] the model's cell for the paper's hopper (another hopper's: this in its lengths)
PAPER_UNITS = units_of(PAPER)
# Terrain cells within this fraction of the model's cell size are the model's cells (a cell size scaled to a
# hopper may differ from the model's scaled cell in its last bits).
SAME_CELL = 1e-9


@dataclass(frozen=True)
class WindowEncoding:
    terrain: np.ndarray   # (n,) heights relative to the ground under the body, in the hopper's lengths, clipped
    apex: np.ndarray      # (3,) height above the ground under the body, forward speed (hopper units), x offset
                          # in its cell (a fraction)
    s0: int               # cell under the body
    x_start: float        # world x of the window's first cell edge
    cell: float           # the window's cell size [m]: the model's cell in the hopper's lengths
    ditch: np.ndarray     # (n,) bool: ditch cells (no foothold possible)

    def bin_of(self, x, subcells: int = 1) -> np.ndarray:
        """The model's output bin of each x: the cell split into ``subcells`` equal parts (1: the cell)."""
        return np.floor((np.asarray(x, dtype=np.float64) - self.x_start) / (self.cell / subcells)).astype(np.int64)

    def x_of_bin(self, bins, subcells: int = 1) -> np.ndarray:
        """Centre of each bin, world x."""
        return self.x_start + (np.asarray(bins, dtype=np.float64) + 0.5) * (self.cell / subcells)

    def s0_bin(self, subcells: int = 1) -> int:
        """The bin under the body (``s0``): its cell, and the part of it the body's offset falls in."""
        return self.s0 * subcells + min(int(float(self.apex[2]) * subcells), subcells - 1)


def pad_steps(a: np.ndarray, t: int, fill=0) -> np.ndarray:
    """``a`` (N, T, ...) padded along its step axis to ``t`` steps with ``fill`` (sequences of several lengths
    stored as one array)."""
    return np.pad(a, ((0, 0), (0, t - a.shape[1])) + ((0, 0),) * (a.ndim - 2), constant_values=fill)


def reference_height(window_heights: np.ndarray, s0: int, ditch: np.ndarray) -> float:
    """The ground the window is measured from: the cell under the body, or, over a ditch, the nearest solid cell
    (behind first, where the hopper came from); ``ditch`` marks the window's ditch cells."""
    solid = np.flatnonzero(~ditch)
    if solid.size == 0:
        return 0.0
    behind = solid[solid <= s0]
    return float(window_heights[behind[-1] if behind.size else solid[0]])


def model_cell(units: HopperUnits) -> float:
    """The model's cell [m] for a hopper of ``units``."""
    return MODEL_CELL * units.length


def relative_heights(heights, ditch, ground, units: HopperUnits) -> np.ndarray:
    """Heights relative to ``ground`` in the hopper's lengths, clipped to [HEIGHT_FLOOR, 1]: what the model and the
    re-ranker read. A ditch's floor counts at least as deep as the paper's ditches (DITCH_HEIGHT, -1 m, in the
    hopper's lengths), so the paper's terrains scaled to a longer-legged hopper encode as they do for the paper's
    hopper (for a shorter leg, a scaled terrain's ditches stay 1 m deep, deeper than the paper's in its lengths,
    which matters only where the ground is below 0: the encoding is clipped at HEIGHT_FLOOR)."""
    floor = min(DITCH_HEIGHT * units.length, 0.0)
    heights = np.where(ditch, np.minimum(heights, floor), heights)
    return np.clip((heights - ground) / units.length, HEIGHT_FLOOR, 1.0)


def model_window(terrain: Terrain, x_body: float, units: HopperUnits):
    """(heights, ditch, x_start, cell, s0) of the model's window around ``x_body``: ``Terrain.window`` when the
    terrain's cells are the model's, else the terrain resampled onto the model's cells (see the module doc),
    anchored on the terrain's start like its own cells."""
    ahead, behind = units.window
    cell = model_cell(units)
    s0 = int(round(behind / cell))   # Terrain.window anchors the body's cell here
    if abs(terrain.cell - cell) <= SAME_CELL * cell:
        heights, x_start = terrain.window(x_body, ahead, behind)
        return heights, heights <= terrain.ditch_height, x_start, terrain.cell, s0
    n = max(1, int(round((ahead + behind) / cell)))
    x_start = terrain.x0 + (math.floor((x_body - terrain.x0) / cell) - s0) * cell
    edges = x_start + np.arange(n + 1) * cell
    touch = SAME_CELL * min(cell, terrain.cell)   # a terrain cell a model cell only touches is not under it
    first, last = terrain.index(edges[:-1] + touch), terrain.index(edges[1:] - touch)
    span = np.arange(int((last - first).max()) + 1)
    cells = np.minimum(first[:, None] + span[None, :], last[:, None])     # every terrain cell under a model cell
    under = terrain.heights[cells]
    ditch = (under <= terrain.ditch_height).any(axis=1)
    heights = np.where(ditch, under.min(axis=1), under.max(axis=1))
    return heights, ditch, x_start, cell, s0


def encode_window(terrain: Terrain, apex: ApexState, units: HopperUnits = PAPER_UNITS) -> WindowEncoding:
    """The model's inputs for ``apex`` over ``terrain``, for a hopper of ``units`` (default: the paper's)."""
    heights, ditch, x_start, cell, s0 = model_window(terrain, apex.x, units)
    ground = reference_height(heights, s0, ditch)
    offset = min(max((apex.x - terrain.x0) / cell - math.floor((apex.x - terrain.x0) / cell), 0.0), 1.0)
    return WindowEncoding(terrain=relative_heights(heights, ditch, ground, units).astype(np.float32),
                          apex=np.array([(apex.z - ground) / units.length, apex.xdot / units.speed, offset],
                                        dtype=np.float32),
                          s0=s0, x_start=x_start, cell=cell, ditch=ditch)
