"""A sound energy argument: the terrain a passive SLIP hopper can never cross, whatever its leg angles.

The model (``drakeslip.dynamics``, ``drakeslip.slip_hopper``) is a point mass on a massless, lossless spring leg. Flight
is ballistic, stance is spring + gravity, and touchdown and liftoff happen at rest leg length L0 with the body
state continuous, so E = m g z + m (xdot^2 + zdot^2) / 2 + k (L0 - l)^2 / 2 (z absolute) keeps the start's value
at every instant. Let H = E / (m g) = z0 + xdot0^2 / (2 g) be the start's *energy height*, c = cos(atan mu) and
s = sin(atan mu) (friction mu). A run that reaches the goal (every hop ends at an apex with no failure; the last
apex is at x >= goal_x: the oracle's success) satisfies:

  (1) x only grows: xdot0 > 0, flight keeps xdot and stance stops (STALL) when xdot reaches 0. So the body passes
      over every x in [x0, goal_x], always above the terrain there (else BODY_COLLISION), and z <= H (kinetic and
      spring energy are >= 0): no cell there is at or above H.
  (2) A touchdown puts the foot on a top surface (a face strike or a ditch is FOOT_COLLISION), at most
      FACE_TOLERANCE below it, with the leg at length L0 at an angle |theta| <= atan mu (else SLIP). So the body is
      at least h + L0 c high at a touchdown on a cell of height h, and z < H there (xdot > 0): no touchdown on a
      cell at or above H - L0 c (the *landing ceiling*). A liftoff (length L0, inside the cone) is at z >= h + L0 c.
  (3) In stance the leg is at most L0 long and inside the cone, so |x - x_foot| <= L0 s.
  (4) A flight from liftoff height a to touchdown height b, with speed^2 = 2 g (H - z_lo), covers at most
      2 sqrt((H - a)(H - b)) in x (a projectile's longest range); from liftoff to its apex at most H - a.
  (5) A flight's path is a parabola with apex height H - xdot^2 / (2 g): the x where it is above a level l form
      one interval no longer than max_u 4 sqrt(u (H - l - u)) = 2 (H - l). So two cells p <= q of the stretch it
      surely flies over (clipped to it) span less than 2 (H - min(h_p, h_q)).

Hence the *cell graph*: its nodes are the landable cells (solid, below the landing ceiling). The start reaches
cell j if its own first descent (known speed: an exact parabola, above the terrain up to L0 s before the cell)
can touch down there by (2) and (3). Cell i reaches cell j if the gap lo_j - hi_i is within 2 L0 s + (4), the foot
goes back by less than 2 L0 s (1, 3), and (5) holds on (hi_i + L0 s, lo_j - L0 s), which only that flight covers.
Cell i ends at the goal if hi_i + L0 s + H - a_i >= goal_x (4) with (5) up to goal_x. The touchdowns of any
successful run are a path of this graph, so **if no path reaches the goal, no run of the model does**: no leg
angles (on no grid), no speeds, no number of hops. That is ``verification.energy_bound.prove_unreachable``
("proved-not-traversable").
Every bound is loosened by ``ENERGY_SLACK`` on H and ``GEOMETRY_SLACK`` on positions, far above the backends'
energy drift (~1e-8 relative a hop) and event tolerances (FACE_TOLERANCE = 1e-5 m), so a claim holds for the
fast step map as it integrates the model. (Drake evaluates its guards at step ends, 2 ms apart, so a Drake run
could clip a corner shorter than that unnoticed: the claim is about the model.)

Run backwards, the graph gives the cells from which the goal can be reached at all (``Coreach``). An apex whose
next touchdown (its exact first descent, by (2) and (3) and the range alone) cannot be on one of them has no way
to the goal, so the oracle's search and the planners' pruned stage (``planners.search.pruned``) drop it without losing
any plan (``Coreach.alive``).
"""
from __future__ import annotations

import math
from collections import deque

import numpy as np

from drakeslip import SlipParams, Terrain

ENERGY_SLACK = 1e-3     # m added to the energy height H: every claim is made as if the hopper had this much more
GEOMETRY_SLACK = 1e-3   # m added to every reach and taken from every clearance (covers FACE_TOLERANCE = 1e-5 m)
# The most cells a graph may have: its edges are a cells x cells matrix of booleans (100 MB here, built in under a
# second). The graph spans the course and twice the energy height above the lowest solid ground (every flight's
# range), so only an apex hundreds of leg lengths above that ground, or a map of cells far finer than the leg,
# comes near it; such a graph is refused (GraphTooLarge): the planners' pruned stage is then skipped, and the
# oracle searches without the energy argument.
MAX_CELLS = 10_000
EDGE_ROWS = 256         # rows of the edge matrix computed at a time


class GraphTooLarge(ValueError):
    """The cell graph of a start would have more than MAX_CELLS cells."""


def energy_height(apex, params: SlipParams) -> float:
    """H = E / (m g) = z + xdot^2 / (2 g) of an apex (x, z, xdot): how high the body could be at rest."""
    return float(apex[1]) + float(apex[2]) ** 2 / (2.0 * params.gravity)


def landing_ceiling(apex, params: SlipParams) -> float:
    """(2): no touchdown is possible on a cell at or above H - L0 cos(atan mu) (here loosened by both slacks)."""
    return energy_height(apex, params) + ENERGY_SLACK + GEOMETRY_SLACK - params.leg_length * _cos_max(params)


def _cos_max(params: SlipParams) -> float:
    return 1.0 / math.sqrt(1.0 + params.friction ** 2)


class CellGraph:
    """The cell graph of one start (module docstring): cells ``lo``/``hi``/``h`` over the stretch that matters,
    ``landable``, ``starts`` (the first descent's cells), ``edges[i, j]`` and ``ends`` (cells that end at the goal)."""

    def __init__(self, apex, terrain: Terrain, goal_x: float, params: SlipParams):
        self.apex, self.goal_x, self.g = tuple(map(float, apex)), float(goal_x), params.gravity
        L0 = params.leg_length
        self.H = energy_height(apex, params) + ENERGY_SLACK
        self.reach = L0 * params.friction * _cos_max(params) + GEOMETRY_SLACK   # (3), loosened
        rise = L0 * _cos_max(params) - GEOMETRY_SLACK                           # (2), loosened
        solid = terrain.heights[terrain.heights > terrain.ditch_height]
        self.far = 2.0 * max(self.H - (solid.min() if solid.size else 0.0) - rise, 0.0)  # bounds every (4)
        first = int(math.floor((self.apex[0] - self.reach - terrain.x0) / terrain.cell)) - 1
        last = int(math.ceil((self.goal_x + 2.0 * self.reach + self.far - terrain.x0) / terrain.cell)) + 1
        if last - first + 1 > MAX_CELLS:
            raise GraphTooLarge(f"the energy graph from x={self.apex[0]:g} to x={self.goal_x:g} at energy height "
                                f"{self.H - ENERGY_SLACK:.4g} m would have {last - first + 1} cells of "
                                f"{terrain.cell:g} m, more than {MAX_CELLS}")
        idx = np.arange(first, last + 1)
        self.lo = terrain.x0 + idx * terrain.cell
        self.hi = self.lo + terrain.cell
        self.h = terrain.heights[np.clip(idx, 0, terrain.heights.size - 1)]
        self.top = self.h + rise                 # the least body height of a touchdown or liftoff on the cell
        self.landable = (self.h > terrain.ditch_height) & (self.top < self.H)
        cells = np.flatnonzero(self.landable)
        self._levels, self._rank = np.unique(self.h, return_inverse=True)
        self.limit = np.full(self.h.size, -np.inf)
        for i in cells:
            a = self.hi[i] + self.reach
            self.limit[i] = max(self.fly_limit(a), a)     # an empty stretch is always flown over
        self.starts = self.first_touchdowns()
        self.edges = np.zeros((self.h.size, self.h.size), dtype=bool)
        j = cells[None, :]
        for rows in np.array_split(cells, max(1, cells.size // EDGE_ROWS)) if cells.size else ():
            i = rows[:, None]   # a block of rows at a time: the float temporaries stay EDGE_ROWS x cells
            span = 2.0 * np.sqrt((self.H - self.top[i]) * (self.H - self.top[j]))
            self.edges[i, j] = ((self.lo[j] - self.hi[i] <= 2.0 * self.reach + span)
                                & (self.hi[j] >= self.lo[i] - 2.0 * self.reach)
                                & (self.lo[j] - self.reach <= self.limit[i]) & (i != j))
        self.ends = self.landable & (self.hi + self.reach + self.H - self.top >= self.goal_x) \
            & (self.goal_x <= self.limit)

    def fly_limit(self, a: float) -> float:
        """(5): the largest b such that one flight can cover the open stretch (a, b): for every pair of cells
        p <= q meeting it, min(hi_q, b) - max(lo_p, a) <= 2 (H - min(h_p, h_q)) (+ slack). Its work grows as n log n
        in the n cells within a flight's range of a (``planners.search.flight_limit``), not as n^2."""
        from planners.search.flight_limit import first_failing_pair   # compiled on first use: importing stays light

        bound = a + 2.0 * self.reach + self.far + 2.0 * self.H + 1.0
        return float(first_failing_pair(float(a), bound, self.lo, self.hi, self.h, self._rank, self._levels.size,
                                        self.H, 2.0 * GEOMETRY_SLACK))

    def flies_over(self, a: float, b: float) -> bool:
        return b <= a or b <= self.fly_limit(a)

    def first_touchdowns(self, apex=None) -> np.ndarray:
        """Landable cells the first descent from ``apex`` (default the start) can touch down on: the body at least
        L0 c above the cell (2), the foot at most L0 s from it (3), and the exact parabola above the terrain up to
        L0 s before the cell."""
        x0, z0, v0 = self.apex if apex is None else tuple(map(float, apex))
        t = np.sqrt(2.0 * np.maximum(z0 - self.top, 0.0) / self.g)
        ok = self.landable & (z0 >= self.top) & (self.lo <= x0 + v0 * t + self.reach) & (self.hi >= x0 - self.reach)
        for j in np.flatnonzero(ok):
            end = self.lo[j] - self.reach
            k = np.flatnonzero((self.hi > x0) & (self.lo < end))
            z = z0 - self.g * (np.minimum(self.hi[k], end) - x0) ** 2 / (2.0 * v0 * v0)
            ok[j] = not np.any(z < self.h[k] - GEOMETRY_SLACK)
        return ok

    def wall(self):
        """(1): the first cell over [x0, goal_x] at or above H, as (lo, height), or None."""
        k = np.flatnonzero((self.hi > self.apex[0]) & (self.lo <= self.goal_x) & (self.h >= self.H))
        return None if k.size == 0 else (float(self.lo[k[0]]), float(self.h[k[0]]))

    def closure(self, sources: np.ndarray, forward: bool = True) -> np.ndarray:
        """The cells reachable from ``sources`` (a mask) along the edges, or backwards along them."""
        adj = self.edges if forward else self.edges.T
        seen = sources.copy()
        todo = deque(np.flatnonzero(seen).tolist())
        while todo:
            new = adj[todo.popleft()] & ~seen
            seen |= new
            todo.extend(np.flatnonzero(new).tolist())
        return seen


def cell_graph(apex, terrain: Terrain, goal_x: float, params: SlipParams) -> CellGraph | None:
    """The CellGraph of a start, or None where it would have more than MAX_CELLS cells."""
    try:
        return CellGraph(apex, terrain, goal_x, params)
    except GraphTooLarge:
        return None


class Coreach:
    """The landable cells from which the goal can be reached in the cell graph: an apex is ``alive`` when it is
    past the goal or its first descent can touch down on one of them (by the range alone)."""

    def __init__(self, graph: CellGraph):
        self.graph = graph
        k = np.flatnonzero(graph.closure(graph.ends, forward=False))
        self.lo, self.hi, self.top = graph.lo[k], graph.hi[k], graph.top[k]

    def alive(self, apexes: np.ndarray) -> np.ndarray:
        """For rows (x, z, xdot). Only the cells within the rows' reach are compared."""
        x, z, v = (apexes[:, i:i + 1] for i in range(3))
        r = self.graph.reach
        far = float(np.max(x + v * np.sqrt(2.0 * np.maximum(z - self.top.min(initial=np.inf), 0.0) / self.graph.g)))
        k = (self.hi >= float(x.min()) - r) & (self.lo <= far + r)
        lo, hi, top = self.lo[k], self.hi[k], self.top[k]
        t = np.sqrt(2.0 * np.maximum(z - top, 0.0) / self.graph.g)
        ok = (z >= top) & (lo <= x + v * t + r) & (hi >= x - r)
        return (apexes[:, 0] >= self.graph.goal_x) | ok.any(axis=1)
