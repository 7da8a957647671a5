"""The level and edge tests of a point on a height map, compiled."""
from __future__ import annotations

from drakeslip.compiled import compiled
from drakeslip.dynamics import height_at
from drakeslip.terrain import LEVEL_TOLERANCE

@compiled()
def same_level(heights, x0, cell, a, b):
    """``Terrain.same_level`` on one pair of points, compiled."""
    return abs(height_at(heights, x0, cell, a) - height_at(heights, x0, cell, b)) <= LEVEL_TOLERANCE


@compiled()
def clear_of_edges_at(heights, x0, cell, x, margin):
    """Whether the height map is level within ``margin`` of x on both sides: no step or ditch edge nearby (a sensed
    map's noise is not an edge, ``Terrain.same_level``)."""
    return same_level(heights, x0, cell, x - margin, x) and same_level(heights, x0, cell, x + margin, x)
