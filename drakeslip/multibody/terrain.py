"""Any ``Terrain`` as collision and visual geometry in a scene graph: one box per run of equal-height cells.

A box's top is the run's height and its sides are the cells' edges, so the robot meets the planner's map: a
ditch (cells at the ditch height, ``Terrain``) is a real gap down to that height, a step a real vertical face.
The first and last heights extend ``EXTENSION`` metres past the map's ends, as ``Terrain`` reads them flat.
"""
from __future__ import annotations

import numpy as np

from drakeslip.terrain import Terrain

EXTENSION = 20.0     # [m] the ground past the map's ends (flat, as Terrain reads it)
FLOOR_DEPTH = 0.5    # [m] the boxes reach this far below the map's lowest height
WIDTH = 2.0          # [m] the boxes' extent across the plane of motion
COLOR = (0.55, 0.50, 0.42, 1.0)


def terrain_runs(terrain: Terrain) -> list[tuple[float, float, float]]:
    """(x_start, x_end, height) of each run of equal-height cells, the ends extended by ``EXTENSION``."""
    h = terrain.heights
    cuts = np.flatnonzero(np.diff(h) != 0) + 1
    starts = np.concatenate([[0], cuts])
    ends = np.concatenate([cuts, [h.size]])
    runs = [[terrain.x0 + terrain.cell * s, terrain.x0 + terrain.cell * e, float(h[s])] for s, e in zip(starts, ends)]
    runs[0][0] -= EXTENSION
    runs[-1][1] += EXTENSION
    return [tuple(r) for r in runs]


def add_terrain(plant, terrain: Terrain, friction: float) -> int:
    """Register ``terrain`` with ``plant``'s scene graph as boxes welded to the world, with Coulomb ``friction``
    (static and dynamic) and the foot's compliant point contact; returns the number of boxes."""
    from pydrake.geometry import Box, ProximityProperties, AddContactMaterial
    from pydrake.math import RigidTransform
    from pydrake.multibody.plant import CoulombFriction

    runs = terrain_runs(terrain)
    floor = min(r[2] for r in runs) - FLOOR_DEPTH
    props = ProximityProperties()
    # far stiffer than the foot, so that the contact's compliance is the foot's (stiffnesses combine in series)
    AddContactMaterial(dissipation=1.0, point_stiffness=1e8, friction=CoulombFriction(friction, friction),
                       properties=props)
    for i, (x_lo, x_hi, top) in enumerate(runs):
        box = Box(x_hi - x_lo, WIDTH, top - floor)
        pose = RigidTransform([(x_lo + x_hi) / 2, 0.0, (top + floor) / 2])
        plant.RegisterCollisionGeometry(plant.world_body(), pose, box, f"terrain_{i}", props)
        plant.RegisterVisualGeometry(plant.world_body(), pose, box, f"terrain_{i}_visual", np.array(COLOR))
    return len(runs)
