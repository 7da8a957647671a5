"""Encoding of the perception window and footholds for the footstep model (shared by the dataset generator,
training and the LSTM planners)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drakeslip import ApexState, Terrain
from drakeslip.terrain import WINDOW_BEHIND

HEIGHT_FLOOR = -1.0  # encoded heights are clipped to [HEIGHT_FLOOR, 1]; a ditch-world ditch (1 m deep) sits on it


@dataclass(frozen=True)
class WindowEncoding:
    terrain: np.ndarray   # (n,) heights relative to the ground under the body, clipped to [-1, 1]
    apex: np.ndarray      # (3,) height above the ground under the body, forward speed, x offset in its cell
    s0: int               # cell under the body
    x_start: float        # world x of the window's first cell edge
    cell: float
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


def reference_height(window_heights: np.ndarray, s0: int, ditch_height: float) -> float:
    """The ground the window is measured from: the cell under the body, or, over a ditch, the nearest solid cell
    (behind first, where the hopper came from)."""
    solid = np.flatnonzero(window_heights > ditch_height)
    if solid.size == 0:
        return 0.0
    behind = solid[solid <= s0]
    return float(window_heights[behind[-1] if behind.size else solid[0]])


def encode_window(terrain: Terrain, apex: ApexState) -> WindowEncoding:
    heights, x_start = terrain.window(apex.x)
    s0 = int(round(WINDOW_BEHIND / terrain.cell))  # Terrain.window anchors the body's cell here
    ground = reference_height(heights, s0, terrain.ditch_height)
    offset = min(max((apex.x - terrain.x0) / terrain.cell - math.floor((apex.x - terrain.x0) / terrain.cell), 0.0), 1.0)
    return WindowEncoding(terrain=np.clip(heights - ground, HEIGHT_FLOOR, 1.0).astype(np.float32),
                          apex=np.array([apex.z - ground, apex.xdot, offset], dtype=np.float32),
                          s0=s0, x_start=x_start, cell=terrain.cell, ditch=heights <= terrain.ditch_height)
