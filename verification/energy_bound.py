"""The oracle's proof that a case cannot be crossed: the cell graph of ``planners.search.energy_graph`` (the energy
argument, stated there: the terrain a passive SLIP hopper can never cross, whatever its leg angles) has no path from
the start to the goal, or a wall the body can never pass."""
from __future__ import annotations

import numpy as np

from drakeslip import SlipParams, Terrain

from planners.search.energy_graph import ENERGY_SLACK, CellGraph, landing_ceiling


def prove_unreachable(apex, terrain: Terrain, goal_x: float, params: SlipParams | None = None,
                      graph: CellGraph | None = None) -> dict | None:
    """None when the energy argument does not settle the case; else why no run of the model from ``apex`` reaches
    ``goal_x``: {"proof": "energy", "energy_height", "landing_ceiling", "reach_x", "statement"}, ``reach_x`` the
    farthest x a foothold can be on (None: the body cannot even pass)."""
    params = params or SlipParams()
    if apex[0] >= goal_x:
        return None
    graph = graph or CellGraph(apex, terrain, goal_x, params)
    out = {"proof": "energy", "energy_height": round(graph.H - ENERGY_SLACK, 6),
           "landing_ceiling": round(landing_ceiling(apex, params), 6)}
    wall = graph.wall()
    if wall is not None:
        return {**out, "reach_x": None, "statement": (
            f"the body can never be as high as the {wall[1]:.3f} m terrain at x = {wall[0]:.2f} m: the energy "
            f"height is {out['energy_height']:.3f} m")}
    reached = graph.closure(graph.starts)
    if np.any(reached & graph.ends):
        return None
    far = float(graph.hi[reached].max()) if reached.any() else float(apex[0])
    return {**out, "reach_x": round(far, 6), "statement": (
        f"at energy height {out['energy_height']:.3f} m no touchdown is possible above {out['landing_ceiling']:.3f} m"
        f" and no flight from a foothold before x = {far:.2f} m lands farther on or reaches the goal")}
