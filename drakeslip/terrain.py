"""Piecewise-constant 1-D terrain and the paper's two random terrain families."""
from __future__ import annotations

import math
import numbers
from collections import namedtuple

import numpy as np

from drakeslip.bounds import CELL, MAX_WINDOW_CELLS, POSITION, TERRAIN_START
from drakeslip.params import check_number, shown

DITCH_HEIGHT = -1.0   # cells at or below this height are holes (ditches), see Terrain
DITCH_WIDTH = (0.2, 0.6)   # [m] the range of the ditch and mixed families' ditch widths
WINDOW_AHEAD = 8.0    # the paper's perception window: 8 m ahead of the body ...
WINDOW_BEHIND = 3.0   # ... and 3 m behind, in 10 cm cells (110 cells); another hopper's is this in its lengths
# Heights that differ by no more than this are one level: a sensed height map is noisy (the realistic noise
# profile's 1 cm per cell, drakeslip.noise), while the terrains here change level by 5 cm or more (a step) or 1 m
# (a ditch). It is a property of the map and its sensor, not of the hopper, so it stays 2 cm for every hopper; a
# level change under 2 cm is no obstacle to a hopper whose leg is 0.3 m or longer.
LEVEL_TOLERANCE = 0.02
# A height map as compiled code reads it: a ``Terrain``'s heights per cell from ``x0``, ``cell`` wide (a cell at or
# below ``ditch_height`` a ditch), and the lowest solid height (``lowest``: how far a flight can fall at most)
Ground = namedtuple("Ground", ["heights", "x0", "cell", "ditch_height", "lowest"])


class Terrain:
    """Height profile made of cells: cell i covers ``[x0 + i*cell, x0 + (i+1)*cell)`` at ``heights[i]``.

    Beyond both ends the first/last height extends flat forever, so a map's end is not where a plan must stop.
    A perception window (``perceived``) is the exception: ``extends_flat=False`` says nothing is known past its
    last cell, and ``known_end`` (the x where knowledge ends; infinite for a map) is where a planner's footholds
    must stop (``planners.base.Problem.window_end``). Heights still read flat past a window's end, as a robot
    assumes. Cells at or below ``ditch_height`` are ditches: a foot that reaches a ditch floor is a
    ``FOOT_COLLISION`` (the hopper cannot stand in a hole). Cell size, start and heights are checked against
    ``drakeslip.bounds`` (CELL, TERRAIN_START, POSITION).
    """

    def __init__(self, heights, cell: float = 0.1, x0: float = -3.0, ditch_height: float = DITCH_HEIGHT,
                 extends_flat: bool = True):
        try:
            h = np.asarray(heights, dtype=np.float64)
        except (OverflowError, TypeError, ValueError):   # an integer too large for a float, text, a ragged list
            h = np.asarray([check_number(v, f"Terrain heights[{j}]", bound=POSITION) for j, v in enumerate(heights)])
        if h.ndim != 1 or h.size == 0:
            raise ValueError(f"Terrain heights must be a non-empty 1-D array, got shape {h.shape}")
        bad = np.flatnonzero(~(np.abs(h) <= POSITION.high))   # NaN compares False
        if bad.size:
            check_number(h[bad[0]], f"Terrain heights[{bad[0]}]", bound=POSITION)
        self.cell = check_number(cell, "Terrain cell size", bound=CELL)
        self.x0 = check_number(x0, "Terrain x0", bound=TERRAIN_START)
        self.ditch_height = check_number(ditch_height, "Terrain ditch_height", bound=POSITION)
        self.extends_flat = bool(extends_flat)
        self.heights = h
        self.heights.setflags(write=False)

    def ground(self) -> Ground:
        """This terrain as compiled code reads it (made once)."""
        if "_ground" not in self.__dict__:
            solid = self.heights[self.heights > self.ditch_height]
            lowest = float((solid if solid.size else self.heights).min())
            self._ground = Ground(self.heights, float(self.x0), float(self.cell), float(self.ditch_height), lowest)
        return self._ground

    @classmethod
    def flat(cls, height: float = 0.0, cell: float = 0.1, x0: float = -3.0, length: float = 30.0) -> "Terrain":
        return cls(np.full(int(round(length / cell)), float(height)), cell, x0)

    @property
    def x_end(self) -> float:
        """The far edge of the last cell."""
        return self.x0 + self.cell * self.heights.size

    @property
    def known_end(self) -> float:
        """Where knowledge of the ground ends: ``x_end`` for a perception window, infinite for a map."""
        return math.inf if self.extends_flat else self.x_end

    def index(self, x):
        """Cell index of x (clamped to the ends, where the terrain extends flat)."""
        i = np.floor((np.asarray(x, dtype=np.float64) - self.x0) / self.cell).astype(np.int64)
        return np.minimum(np.maximum(i, 0), self.heights.size - 1)  # np.clip costs 5x more per call here

    def height_at(self, x):
        if type(x) is float and math.isfinite(x):   # one point: ``index``'s cell without numpy's per-call cost
            return float(self.heights[min(max(math.floor((x - self.x0) / self.cell), 0), self.heights.size - 1)])
        h = self.heights[self.index(x)]
        return float(h) if np.ndim(h) == 0 else h

    def same_level(self, a, b):
        """Whether the terrain at ``a`` and at ``b`` is one level (within LEVEL_TOLERANCE), elementwise."""
        return np.abs(self.height_at(a) - self.height_at(b)) <= LEVEL_TOLERANCE

    def denoised(self, sigma: float, window: int = 5) -> "Terrain":
        """This map with the height of each solid cell replaced by the lower median of the solid cells within
        ``window // 2`` cells of it, where at least 3 such cells exist and their median is within 3 ``sigma`` of
        the cell's own height. A sensed map whose cell heights carry independent errors of std ``sigma`` comes
        out with errors a third smaller (rms, over 5 cells, on the suites' terrains), and adjacent cells of one
        level mostly share a height, so they no longer look like small steps; a level change of more than
        3 ``sigma`` (a step, a sliver of another level beside a ditch) is kept as it is, and the lower median is
        always one of the heights seen, so a noiseless piecewise-constant map whose levels differ by more than
        3 ``sigma`` is returned unchanged. Ditch cells are kept."""
        sigma = check_number(sigma, "denoised sigma")
        window = check_window(window, "denoised window")
        if sigma <= 0 or window < 3:
            return self
        h, half = self.heights, window // 2
        solid = h > self.ditch_height
        padded = np.pad(np.where(solid, h, np.nan), half, constant_values=np.nan)
        around = np.lib.stride_tricks.sliding_window_view(padded, window)   # (n, window), NaN: ditch or off map
        count = np.count_nonzero(~np.isnan(around), axis=1)
        ordered = np.sort(around, axis=1)                                    # NaNs sort last
        median = ordered[np.arange(h.size), np.maximum(count - 1, 0) // 2]
        use = solid & (count >= 3) & (np.abs(median - h) <= 3.0 * sigma)
        return Terrain(np.where(use, median, h), self.cell, self.x0, self.ditch_height, self.extends_flat)

    def without_footholds_before_rises(self, width: float) -> "Terrain":
        """This map with every solid cell from which the ground rises by more than LEVEL_TOLERANCE within
        ``width`` [m] ahead (the next ``ceil(width / cell)`` cells) made a ditch cell, so that a planner on it
        places no foothold just before a step's face. ``width`` 0 returns this map."""
        width = check_number(width, "keep-out width")
        ahead = math.ceil(round(width / self.cell, 9))
        if ahead <= 0:
            return self
        h = self.heights
        solid = h > self.ditch_height
        # past a map's end the ground extends flat; past a window's end nothing is known, so nothing rises there
        padded = np.pad(np.where(solid, h, -np.inf), (0, ahead), mode="edge" if self.extends_flat else "constant",
                        constant_values=-np.inf)
        highest_ahead = np.max(np.lib.stride_tricks.sliding_window_view(padded[1:], ahead), axis=1)
        keep_out = solid & (highest_ahead - h > LEVEL_TOLERANCE)
        if not keep_out.any():
            return self
        return Terrain(np.where(keep_out, self.ditch_height, h), self.cell, self.x0, self.ditch_height,
                       self.extends_flat)

    def is_ditch_at(self, x) -> bool:
        return bool(self.height_at(x) <= self.ditch_height)

    def far_rim(self, x: float):
        """Where a ditch under ``x`` ends: (x, height) of the first solid cell ahead, or None when ``x`` is not
        over a ditch or no solid cell follows."""
        if not self.is_ditch_at(x):
            return None
        ahead = np.flatnonzero(self.heights[self.index(x):] > self.ditch_height)
        if ahead.size == 0:
            return None
        i = int(self.index(x)) + int(ahead[0])
        return self.x0 + i * self.cell, float(self.heights[i])

    def window(self, x_body: float, ahead: float = WINDOW_AHEAD, behind: float = WINDOW_BEHIND):
        """The perception window around the body: ``(heights, x_start)`` with ``(ahead+behind)/cell`` cells (at
        least one, at most MAX_WINDOW_CELLS) aligned to the terrain grid, cell j covering
        ``[x_start + j*cell, x_start + (j+1)*cell)``."""
        n = max(1, int(round((ahead + behind) / self.cell)))
        if n > MAX_WINDOW_CELLS:
            raise ValueError(f"a window of {ahead + behind:g} m in {self.cell:g} m cells has {n} cells, more than "
                             f"the {MAX_WINDOW_CELLS} a window may hold")
        # Anchored on the body's cell so the body always sits in cell round(behind / cell) of the window.
        first = int(math.floor((x_body - self.x0) / self.cell)) - int(round(behind / self.cell))
        idx = np.clip(np.arange(first, first + n), 0, self.heights.size - 1)
        return self.heights[idx].copy(), self.x0 + first * self.cell

    def perceived(self, x_body: float, ahead: float = WINDOW_AHEAD, behind: float = WINDOW_BEHIND) -> "Terrain":
        """What the robot sees with its body at ``x_body``: the perception window (``ahead`` and ``behind`` the
        body [m]; the paper's hopper's by default, ``HopperUnits.window`` for another) as a Terrain of its own,
        known only up to its last cell (``extends_flat=False``)."""
        heights, x_start = self.window(x_body, ahead, behind)
        return Terrain(heights, self.cell, x_start, self.ditch_height, extends_flat=False)

    def to_dict(self) -> dict:
        """The cells (a map: files hold the whole terrain, never a perception window)."""
        return {"x0": self.x0, "cell": self.cell, "heights": [float(v) for v in self.heights]}

    @classmethod
    def from_dict(cls, d: dict) -> "Terrain":
        for key in ("x0", "cell", "heights"):
            if key not in d:
                raise ValueError(f"terrain is missing the field {key!r}")
        return cls(d["heights"], cell=d["cell"], x0=d["x0"])

    def __repr__(self):
        window = "" if self.extends_flat else ", extends_flat=False"
        return f"Terrain(n={self.heights.size}, cell={self.cell}, x0={self.x0}{window})"


# The widest median filter window, in cells. The filter takes out a sensor's per-cell errors over ground of one level:
# 25 cells are 2.5 m of the planar maps' 10 cm cells and 1.25 m of the height maps' 5 cm, over twice their shortest
# levels (0.4 m islands, 0.6 m step segments, 0.3 m stair treads), so a wider window sees mostly other levels, whose
# median its 3 sigma test refuses, leaving the noise. On a height map it sorts window^2 heights per cell: 25 cells
# take about 0.7 s and 200 MB per hop for the 3D loop's 81 x 221-cell perception window, 99 cells 11 s and 2.7 GB
# (a 1001-cell window asked for 134 GiB). The robust presets filter over 5 cells.
MAX_FILTER_WINDOW = 25


def check_window(window, name: str) -> int:
    """``window`` as an int if it is a filter window of cells: odd (a cell and as many on each side), 1 to
    MAX_FILTER_WINDOW; else ValueError naming ``name`` and the value."""
    if isinstance(window, (bool, np.bool_)) or not isinstance(window, numbers.Integral) or window < 1 \
            or window % 2 == 0 or window > MAX_FILTER_WINDOW:
        raise ValueError(f"{name} must be odd (a cell and as many on each side), from 1 to {MAX_FILTER_WINDOW}, "
                         f"got {shown(window)}")
    return int(window)


def _cells(length: float, cell: float) -> int:
    return max(1, int(round(length / cell)))


def ditch_world(seed: int, x0: float = -3.0, x_end: float = 20.0, cell: float = 0.1, flat_until: float = 1.0,
                ditch_width=DITCH_WIDTH, island_length=(0.4, 1.5)) -> Terrain:
    """Ground at 0 with ditches (holes at DITCH_HEIGHT) of width 0.2-0.6 m between islands of 0.4-1.5 m;
    flat for x < ``flat_until``. Widths are whole cells."""
    rng = np.random.default_rng(seed)
    n = _cells(x_end - x0, cell)
    heights = np.zeros(n)
    i = _cells(flat_until - x0, cell)
    while i < n:
        w = _cells(rng.uniform(*ditch_width), cell)
        heights[i:i + w] = DITCH_HEIGHT
        i += w + _cells(rng.uniform(*island_length), cell)
    return Terrain(heights, cell, x0)


def step_world(seed: int, x0: float = -3.0, x_end: float = 20.0, cell: float = 0.1, flat_until: float = 1.0,
               change=(0.05, 0.25), level_range=(-0.3, 0.5), segment_length=(0.6, 2.0)) -> Terrain:
    """Piecewise-constant levels, each change +-0.05-0.25 m, kept in -0.3...0.5 m, segments 0.6-2.0 m long;
    flat at 0 for x < ``flat_until``."""
    rng = np.random.default_rng(seed)
    n = _cells(x_end - x0, cell)
    heights = np.zeros(n)
    i = _cells(flat_until - x0, cell)
    level = 0.0
    while i < n:
        step = rng.uniform(*change) * rng.choice((-1.0, 1.0))
        if not level_range[0] <= level + step <= level_range[1]:
            step = -step  # reflect at the band's edge so every change keeps its size
        level = round(level + step, 4)
        seg = _cells(rng.uniform(*segment_length), cell)
        heights[i:i + seg] = level
        i += seg
    return Terrain(heights, cell, x0)


def mixed_world(seed: int, x0: float = -3.0, x_end: float = 20.0, cell: float = 0.1, flat_until: float = 1.0,
                ditch_width=DITCH_WIDTH) -> Terrain:
    """Steps and ditches on one terrain: a step world with some islands cut by ditches ``ditch_width`` wide."""
    rng = np.random.default_rng(seed)
    base = step_world(seed, x0, x_end, cell, flat_until).heights.copy()
    i = _cells(flat_until - x0, cell) + _cells(rng.uniform(0.4, 1.5), cell)
    while i < base.size:
        w = _cells(rng.uniform(*ditch_width), cell)
        base[i:i + w] = DITCH_HEIGHT
        i += w + _cells(rng.uniform(0.8, 2.5), cell)
    return Terrain(base, cell, x0)


TERRAIN_FAMILIES = {"ditch": ditch_world, "step": step_world, "mixed": mixed_world}


def check_families(names) -> tuple:
    """``names`` as a tuple when it lists one or more terrain families of ``TERRAIN_FAMILIES``; else a ValueError
    naming the unknown ones and the known families."""
    return check_names(names, TERRAIN_FAMILIES, "terrain families")


def check_names(names, known: dict, kind: str) -> tuple:
    """``names`` as a tuple when it lists one or more keys of ``known``; else a ValueError naming the unknown ones,
    ``kind`` and the known names (the planar and the height-map families are checked alike)."""
    names = tuple(names)
    unknown = [name for name in names if not isinstance(name, str) or name not in known]
    if unknown or not names:
        raise ValueError(f"unknown {kind} {unknown}; choose from {sorted(known)}")
    return names


def family(name: str):
    """The generator of the terrain family ``name`` (``family("ditch")(seed)`` is ``ditch_world(seed)``); a
    ValueError naming the known families for any other name."""
    return TERRAIN_FAMILIES[check_families([name])[0]]
