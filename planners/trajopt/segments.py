"""The discrete part of the problem: the terrain's flat runs of cells ("segments"), the segment each of a seed's
footholds lands on (which fixes it for the optimizer), and the highest terrain under an interval (for the
clearance constraints; the terrain is piecewise constant).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drakeslip import Terrain
from planners.trajopt.config import TrajoptError


@dataclass(frozen=True)
class Segment:
    """A maximal run of cells at one height: x in [lo, hi) (lo = -inf / hi = +inf where the terrain extends
    flat beyond its ends)."""

    lo: float
    hi: float
    height: float
    ditch: bool

    def contains(self, x: float) -> bool:
        return self.lo <= x < self.hi

    def to_dict(self) -> dict:
        return {"lo": self.lo, "hi": self.hi, "height": self.height}


def segments(terrain: Terrain) -> list[Segment]:
    """The terrain's flat runs of cells, left to right."""
    h = terrain.heights
    breaks = np.flatnonzero(np.diff(h) != 0) + 1
    starts = np.concatenate([[0], breaks])
    ends = np.concatenate([breaks, [h.size]])
    out = []
    for k, (a, b) in enumerate(zip(starts, ends)):
        lo = -math.inf if k == 0 else terrain.x0 + a * terrain.cell
        hi = math.inf if k == len(starts) - 1 else terrain.x0 + b * terrain.cell
        out.append(Segment(float(lo), float(hi), float(h[a]), bool(h[a] <= terrain.ditch_height)))
    return out


def segment_of(terrain: Terrain, x: float) -> Segment:
    """The segment under x (the cell convention: a cell edge belongs to the cell on its right)."""
    for seg in segments(terrain):
        if seg.contains(x):
            return seg
    raise AssertionError("segments cover the real line")


def assign_segments(terrain: Terrain, footholds, margin: float, window_end: float = math.inf) -> list[Segment]:
    """The segment each foothold lands on, clipped to ``window_end``. Raises TrajoptError for a foothold on a
    ditch segment, or on a segment too short to hold a foothold ``margin`` away from both edges."""
    out = []
    for i, x in enumerate(np.asarray(footholds, dtype=np.float64)):
        if not math.isfinite(x):
            raise TrajoptError(f"foothold {i} is not finite: {x!r}")
        seg = segment_of(terrain, float(x))
        where = f"foothold {i} (x={x:.3f} m)"
        if seg.ditch:
            raise TrajoptError(f"{where} lies on a ditch segment [{seg.lo:.2f}, {seg.hi:.2f}) m at height "
                               f"{seg.height:g}: a foot cannot land in a ditch, so the seed cannot be optimized")
        seg = Segment(seg.lo, min(seg.hi, window_end), seg.height, False)
        if seg.hi - seg.lo <= 2 * margin:
            raise TrajoptError(f"{where} lies on a segment [{seg.lo:.2f}, {seg.hi:.2f}) m too short for a foothold "
                               f"{margin} m from both edges")
        out.append(seg)
    return out


def max_height(terrain: Terrain, a: float, b: float) -> float:
    """Highest terrain over x in [min(a, b), max(a, b)]."""
    i, j = terrain.index(min(a, b)), terrain.index(max(a, b))
    return float(terrain.heights[int(i):int(j) + 1].max())


def max_heights(terrain: Terrain, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``max_height`` for arrays of interval ends."""
    i, j = terrain.index(np.minimum(a, b)), terrain.index(np.maximum(a, b))
    h = terrain.heights
    return np.array([h[p:q + 1].max() for p, q in zip(i.tolist(), j.tolist())])
