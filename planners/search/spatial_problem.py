"""A planning query on a height map, its inputs checked: ``planners.base.Problem`` in the plane.

The goal is a point (x, y). The footholds stay in the known window: the map's cells (all of them for a map; a
perception window's own) within ``horizon`` of the body. When the goal lies beyond the horizon the target is the
point TARGET_MARGIN short of it on the way from the body to the goal. A sequence reaches the goal when a hop's way,
from the foothold before it (the body, for the first hop) to its own, passes within GOAL_RADIUS of it (``goal_reach``:
a finish that does not turn with the body, and one a hop cannot pass aside and land behind); it reaches a target on
the way when a foothold lands past that target's line within the window's half width of it (the plan may go round
what lies between; ``planners.core.spatial_tree.reaches``)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from drakeslip.bounds import HORIZON, POSITION
from drakeslip.params import SlipParams, check_number, shown
from drakeslip.spatial.heightmap import HeightMap
from drakeslip.spatial.state import check_apex3d
from drakeslip.terrain import WINDOW_AHEAD
from drakeslip.units import HopperUnits, units_of

from planners.base import TARGET_MARGIN, Timing
from planners.core.spatial_tree import SpatialTarget

GOAL_RADIUS = 0.5   # [m] a plan that reaches the goal passes this close to it (paper's hopper's lengths)
WINDOW_ASIDE = 2.0  # [m] the perception window reaches this far to either side of the body (paper's hopper's)


@dataclass(frozen=True)
class SpatialProblem:
    """One planning query on a height map: the apex (x, y, z, xdot, ydot), the map, the goal (x, y), the hopper, the
    known window (x_min, x_max, y_min, y_max) the footholds stay in, the target (x, y), what a foothold must reach
    (module doc), and the deadline."""

    apex: tuple
    height_map: HeightMap
    goal: tuple
    params: SlipParams
    units: HopperUnits
    window: tuple
    target: tuple
    reach: SpatialTarget
    deadline: float
    timing: Timing = field(default_factory=Timing)

    @property
    def target_x(self) -> float:
        """The target's x (a Plan's ``target_x``; ``target`` holds both coordinates)."""
        return self.target[0]


def check_goal(goal) -> tuple:
    """``goal`` as (x, y) floats inside POSITION; ValueError naming it otherwise."""
    try:
        gx, gy = goal
    except (TypeError, ValueError):
        raise ValueError(f"goal on a height map must be a point (x, y), got {shown(goal)}") from None
    return check_number(gx, "goal x", bound=POSITION), check_number(gy, "goal y", bound=POSITION)


# many parameters: Planner.plan's inputs and the planner's horizon and budget
def spatial_problem(apex, height_map: HeightMap, goal, params: SlipParams | None, horizon: float | None,
                    t0: float, max_time_s: float) -> SpatialProblem:
    """The checked query (module doc); ValueError or TypeError naming a bad input."""
    params = SlipParams() if params is None else params
    apex = check_apex3d(apex, height_map, params)
    if math.hypot(apex[3], apex[4]) <= 0:
        raise ValueError(f"apex ({', '.join(f'{v:g}' for v in apex)}) has no horizontal speed: the planners hop on")
    goal = check_goal(goal)
    units = units_of(params)
    horizon = units.length_or(None if horizon is None else check_number(horizon, "horizon", bound=HORIZON),
                              WINDOW_AHEAD)
    margin = TARGET_MARGIN * units.length
    if horizon <= margin:
        raise ValueError(f"horizon must be a distance above the target margin, {margin:g} m for this hopper, "
                         f"got {horizon!r}")
    x, y = apex[0], apex[1]
    window = (x - horizon, x + horizon, y - horizon, y + horizon)
    if not height_map.extends_flat:   # a perception window: nothing is known past its cells
        x_min, x_max, y_min, y_max = height_map.extent
        window = (max(window[0], x_min), min(window[1], x_max), max(window[2], y_min), min(window[3], y_max))
    dx, dy = goal[0] - x, goal[1] - y
    distance = math.hypot(dx, dy)
    if distance <= horizon - margin:
        target, reach = goal, goal_reach(goal, GOAL_RADIUS * units.length)
    else:
        hx, hy, ahead = dx / distance, dy / distance, horizon - margin
        target = (x + ahead * hx, y + ahead * hy)
        reach = SpatialTarget(float(target[0]), float(target[1]), hx, hy, WINDOW_ASIDE * units.length, 0.0)
    return SpatialProblem(apex, height_map, goal, params, units, window, target, reach, t0 + max_time_s)


def goal_reach(goal, radius: float) -> SpatialTarget:
    """What a hop must reach for a plan to reach ``goal`` (module doc): its way passes within ``radius`` of it. The
    loop that flies the plan asks the same (``planners.spatial_loop.passes_goal``)."""
    return SpatialTarget(float(goal[0]), float(goal[1]), 1.0, 0.0, -1.0, float(radius))
