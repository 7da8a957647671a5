"""Replays and figures of the spatial robot's runs: the robot's own geometry and colours (``robot.sdf``: body box,
gimbal, upper leg, lower leg and foot) posed from a logged trajectory (``GaitLog`` of a run with its trajectory) over
the height map, in the spatial SLIP's scene (``drakeslip.spatial.meshcat_replay``).

``write_spatial_robot_replay`` writes a self-contained Meshcat HTML (no server: it opens offline): the map's cells
around the run as boxes, the body's path, the planned against the executed footholds, the failure marked and named, the
perspective camera following the body, under a header with the run's outcome and a legend. ``plot_spatial_robot_run``
draws the run as ``drakeslip.spatial.viz.plot_run3d`` draws the SLIP's: the map from above and the profile along the
path.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from drakeslip.multibody.replay import RobotGeometry
from drakeslip.replay_scene import play, write_page
from drakeslip.spatial.heightmap import HeightMap
from drakeslip.spatial.meshcat_replay import draw_markers, draw_terrain, legend_items, set_view
from drakeslip.spatial.multibody.gait import GaitLog
from drakeslip.spatial.multibody.robot import SpatialRobotParams
from drakeslip.spatial.viz import foothold_points

PART_NAMES = {"body_visual": "body", "gimbal_visual": "hip gimbal", "leg_visual": "upper leg",
              "shin_visual": "lower leg", "foot_visual": "foot"}


class SpatialRobotModel(RobotGeometry):
    """The spatial robot's ``RobotGeometry`` (``drakeslip.multibody.replay``): body, hip gimbal, leg and foot, the
    body's path in x, y and z."""

    PART_NAMES = PART_NAMES

    def __init__(self, robot: SpatialRobotParams | None = None):
        from drakeslip.spatial.multibody.robot import add_spatial_hopper

        super().__init__(robot or SpatialRobotParams(), add_spatial_hopper, ("body", "gimbal", "leg", "foot"))

    def body_path(self, positions: np.ndarray) -> np.ndarray:
        """(N, 3) x, y, z of the body at each row of ``positions``."""
        return positions[:, list(self.layout.position)]


def failure_marker(log: GaitLog):
    """(time, body (x, y, z), name) of the run's failure, or None."""
    f = log.failure
    return None if f is None else (f.time, f.state[:3], f.mode.name)


# many parameters: the run, its map and plan, then the animation's keywords as ``draw_replay3d`` takes them
def draw_spatial_robot_replay(meshcat, log: GaitLog, height_map: HeightMap, planned_footholds=None,
                              model: SpatialRobotModel | None = None, *, fps: float = 30.0, speed: float = 1.0,
                              prefix: str = "/drakeslip") -> int:
    """Draw the run of ``log`` on ``height_map`` into ``meshcat`` under ``prefix`` (deleting what was there), set the
    camera that follows the body and the animation (``speed`` times real time, ``fps`` frames a second) as
    ``drakeslip.spatial.meshcat_replay.draw_replay3d`` does for the SLIP, the robot's links under
    ``prefix``/world/robot posed from the logged sample at or before each frame's time. ``planned_footholds`` are
    (x, y) (on the map) or (x, y, z) rows. Returns the number of animation frames."""
    from pydrake.math import RigidTransform

    model = model or SpatialRobotModel()
    positions = model.positions(log)   # ValueError for a run logged without its trajectory
    times, path = np.asarray(log.times, dtype=float), model.body_path(positions)
    root = prefix.rstrip("/")
    world = f"{root}/world"
    planned = foothold_points(planned_footholds, height_map)
    meshcat.Delete(root)
    set_view(meshcat, float(np.nan_to_num(height_map.height_at(*path[0, :2]))))
    draw_terrain(meshcat, height_map, np.concatenate([path[:, :2], planned[:, :2]]), world)
    shown_from = draw_markers(meshcat, path, log.touchdowns, failure_marker(log), planned, world)
    robot = f"{world}/robot"
    for link, name, shape, in_link, colour in model.parts:
        meshcat.SetObject(f"{robot}/{link}/{name}", shape, colour)
        meshcat.SetTransform(f"{robot}/{link}/{name}", in_link)

    def frame_at(t):
        i = min(max(int(np.searchsorted(times, t, side="right")) - 1, 0), len(times) - 1)
        poses = {f"{robot}/{link}": x for link, x in model.poses(positions[i]).items()}
        poses[world] = RigidTransform([-path[i, 0], -path[i, 1], 0.0])
        return poses, []

    return play(meshcat, times[0], times[-1], frame_at, shown_from, fps=fps, speed=speed)


# many parameters: ``draw_spatial_robot_replay``'s, with the page's path, title and robot
def write_spatial_robot_replay(log: GaitLog, height_map: HeightMap, path, planned_footholds=None,
                               title: str | None = None, robot: SpatialRobotParams | None = None, *,
                               fps: float = 30.0, speed: float = 1.0) -> Path:
    """Write the HTML replay of ``log`` on ``height_map`` to ``path`` (see ``draw_spatial_robot_replay``); returns the
    Path."""
    from pydrake.geometry import Meshcat

    model = SpatialRobotModel(robot)
    meshcat = Meshcat()
    try:
        draw_spatial_robot_replay(meshcat, log, height_map, planned_footholds, model, fps=fps, speed=speed)
        f = log.failure
        outcome = "no failure" if f is None else \
            f"failed: {f.mode.name} ({f.what}) at t = {f.time:.2f} s, (x, y) = ({f.state[0]:.2f}, {f.state[1]:.2f}) m"
        roll, pitch = log.max_attitude()
        summary = f"{len(log.touchdowns)} touchdowns, {outcome}; largest body roll {roll:.2f}, pitch {pitch:.2f} rad"
        planned = planned_footholds is not None and len(planned_footholds) > 0
        items = legend_items(model.legend_items(), planned, f is not None)
        return write_page(meshcat, path, title or "spatial robot replay", summary, items, speed=speed, fps=fps)
    finally:
        del meshcat


def plot_spatial_robot_run(log: GaitLog, height_map: HeightMap, planned_footholds=None, title: str = "",
                           robot: SpatialRobotParams | None = None, *, goal=None):
    """The run at a glance (``drakeslip.spatial.viz.plot_run3d``): the body's path, the feet's touchdowns, the planned
    footholds, the goal and the failure. Returns the Figure."""
    from drakeslip.spatial.viz import plot_run3d

    model = SpatialRobotModel(robot)
    path = model.body_path(model.positions(log))
    f = log.failure
    failure = None if f is None else (f.state[:3], None, f.mode.name)
    return plot_run3d(height_map, path, [t[1:4] for t in log.touchdowns], planned_footholds, failure, title,
                      goal=goal)
