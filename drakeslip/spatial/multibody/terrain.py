"""A ``HeightMap`` as collision and visual geometry in a scene graph: one box per rectangle of equal cells.

Each row's runs of equal height are merged with the same runs of the rows after it into rectangles
(``drakeslip.spatial.heightmap.merge_cells``, as the replay draws them), so a stair of straight treads is a box a
tread and a flat map one box. A box's top is its cells' height and its sides are their
edges, so the robot meets the planner's map: a hole (NaN) has no box at all, a step is a vertical face. A map
extends flat past its edges (``HeightMap``): the rectangles on an edge reach ``EXTENSION`` past it.
"""
from __future__ import annotations

import numpy as np

from drakeslip.multibody.terrain import COLOR, EXTENSION, FLOOR_DEPTH
from drakeslip.spatial.heightmap import HeightMap, merge_cells


def height_map_boxes(height_map: HeightMap) -> list[tuple]:
    """(x_lo, x_hi, y_lo, y_hi, top) of each rectangle of equal cells (``merge_cells``; holes left out), those on an
    edge extended by EXTENSION past it when the map extends flat."""
    ny, nx = height_map.shape
    c, (x0, y0) = height_map.cell, height_map.origin
    grow = EXTENSION if height_map.extends_flat else 0.0
    return [(x0 + i0 * c - (grow if i0 == 0 else 0.0), x0 + i1 * c + (grow if i1 == nx else 0.0),
             y0 + j0 * c - (grow if j0 == 0 else 0.0), y0 + j1 * c + (grow if j1 == ny else 0.0), top)
            for j0, j1, i0, i1, top in merge_cells(height_map.heights)]


def add_height_map(plant, height_map: HeightMap, friction: float) -> int:
    """Register ``height_map`` with ``plant``'s scene graph as boxes welded to the world, reaching FLOOR_DEPTH below
    its lowest cell, with Coulomb ``friction`` and a surface far stiffer than the foot; returns the number of
    boxes."""
    from pydrake.geometry import AddContactMaterial, Box, ProximityProperties
    from pydrake.math import RigidTransform
    from pydrake.multibody.plant import CoulombFriction

    boxes = height_map_boxes(height_map)
    floor = float(np.nanmin(height_map.heights)) - FLOOR_DEPTH
    props = ProximityProperties()
    AddContactMaterial(dissipation=1.0, point_stiffness=1e8, friction=CoulombFriction(friction, friction),
                       properties=props)
    for k, (x_lo, x_hi, y_lo, y_hi, top) in enumerate(boxes):
        box = Box(x_hi - x_lo, y_hi - y_lo, top - floor)
        pose = RigidTransform([(x_lo + x_hi) / 2, (y_lo + y_hi) / 2, (top + floor) / 2])
        plant.RegisterCollisionGeometry(plant.world_body(), pose, box, f"terrain_{k}", props)
        plant.RegisterVisualGeometry(plant.world_body(), pose, box, f"terrain_{k}_visual", np.array(COLOR))
    return len(boxes)
