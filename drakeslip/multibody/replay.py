"""Replays and figures of multibody runs: the robot's own geometry and colours (``robot.sdf``: body box, upper
leg, lower leg and foot) posed from a logged trajectory (``HopLog`` with ``trajectory=True``).

``write_robot_replay`` writes a self-contained Meshcat HTML (no server: it opens offline) of the robot over the
scene the SLIP's replay has (``drakeslip.replay_scene``): seen side-on, the camera following the body, the body's
path, the planned against the executed footholds, the plans' predicted apexes and the failure, marked and named,
under a header with the run's outcome and a legend. ``plot_robot_run`` draws the run to scale as
``drakeslip.viz.plot_trajectory`` draws the SLIP's: the body's path, the leg (hip to foot) at every touchdown and
liftoff, the footholds and apexes.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from drakeslip.multibody.failures import HopLog
from drakeslip.multibody.robot import RobotParams
from drakeslip.replay_scene import Y_HOPPER, Scene, animate, draw_scene, legend, points, pose, write_page
from drakeslip.terrain import Terrain

# [m] kept above the body's path: the body box's corners reach 0.21 m from its centre (the paper's hopper's robot; a
# hopper's own, in its lengths)
HEADROOM = 0.26
PART_NAMES = {"body_visual": "body", "leg_visual": "upper leg", "shin_visual": "lower leg", "foot_visual": "foot"}


class RobotGeometry:
    """A robot alone (no terrain) in a plant and scene graph, parsed by ``add(plant, robot)`` (its parts: ``model``
    and ``layout(plant)``): ``parts`` lists (link, geometry name, shape, pose in the link, rgba) of the illustration
    geometry of its ``links``, as its SDF gives them, and ``poses`` gives the links' poses in the world for a position
    vector of the plant it ran in (as a log's ``positions`` holds them: the terrain adds none). ``PART_NAMES`` names
    the parts in a legend."""

    PART_NAMES: dict = {}

    def __init__(self, robot, add, links: tuple):
        from pydrake.geometry import Role
        from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
        from pydrake.systems.framework import DiagramBuilder

        self.robot = robot
        self._builder = DiagramBuilder()   # owns the plant and the scene graph
        plant, scene_graph = AddMultibodyPlant(MultibodyPlantConfig(time_step=robot.time_step), self._builder)
        hopper = add(plant, robot)
        plant.Finalize()
        self.plant, self.context = plant, plant.CreateDefaultContext()
        self.layout = hopper.layout(plant)
        self.links = {name: plant.GetBodyByName(name, hopper.model) for name in links}
        inspector = scene_graph.model_inspector()
        self.parts = []
        for name, link in self.links.items():
            for geometry in inspector.GetGeometries(plant.GetBodyFrameIdOrThrow(link.index()), Role.kIllustration):
                colour = inspector.GetIllustrationProperties(geometry).GetProperty("phong", "diffuse")
                self.parts.append((name, inspector.GetName(geometry).split("::")[-1], inspector.GetShape(geometry),
                                   inspector.GetPoseInFrame(geometry), colour))

    def positions(self, log) -> np.ndarray:
        """The logged positions as an (N, nq) array, checked against this plant."""
        positions = np.asarray(log.positions, dtype=float)
        if positions.ndim != 2 or positions.shape[1] != self.plant.num_positions():
            raise ValueError(f"the log's positions ({positions.shape}) are not this robot's "
                             f"({self.plant.num_positions()} a step): run it with its trajectory")
        return positions

    def poses(self, q) -> dict:
        """{link name: RigidTransform in the world} at the plant positions ``q``."""
        self.plant.SetPositions(self.context, q)
        return {name: self.plant.EvalBodyPoseInWorld(self.context, link) for name, link in self.links.items()}

    def legend_items(self) -> list:
        return [(tuple(colour.rgba[:3]), self.PART_NAMES.get(name, name)) for _, name, _, _, colour in self.parts]


class RobotModel(RobotGeometry):
    """The planar robot's ``RobotGeometry``: body, leg and foot, the body's path in x and z."""

    PART_NAMES = PART_NAMES

    def __init__(self, robot: RobotParams | None = None):
        from drakeslip.multibody.robot import add_hopper

        super().__init__(robot or RobotParams(), add_hopper, ("body", "leg", "foot"))

    def body_path(self, positions: np.ndarray) -> np.ndarray:
        """(N, 2) x, z of the body (the hip) at each row of ``positions``."""
        return positions[:, [self.layout.q[0], self.layout.q[1]]]

    def hip_and_foot(self, q):
        """((x, z) of the hip, (x, z) of the foot's lowest point) at the plant positions ``q``."""
        poses = self.poses(q)
        hip, foot = poses["body"].translation(), poses["foot"].translation()
        return (hip[0], hip[2]), (foot[0], foot[2] - self.robot.foot_radius)


def _scene(log: HopLog, model: RobotModel, terrain: Terrain, planned_footholds, predicted_apexes) -> Scene:
    footholds = np.asarray(log.footholds, dtype=float)
    touchdowns = np.column_stack([log.touchdown_times, footholds, terrain.height_at(footholds)])
    failure = log.failure
    return Scene(terrain, np.asarray(log.times, dtype=float), model.body_path(model.positions(log)), touchdowns,
                 points(planned_footholds, terrain), points(predicted_apexes, terrain),
                 None if failure is None else (failure.time, failure.state[0], failure.state[1], failure.mode.name),
                 0.05 * model.robot.slip.leg_length / 0.5, HEADROOM * model.robot.slip.leg_length / 0.5)


# many parameters: the run and its plan, then the animation's keywords as ``meshcat_replay.draw_replay`` takes them
def draw_robot_replay(meshcat, log: HopLog, terrain: Terrain, planned_footholds=None, predicted_apexes=None,
                      model: RobotModel | None = None, *, fps: float = 30.0, speed: float = 1.0,
                      follow: bool = True) -> int:
    """Draw the run of ``log`` on ``terrain`` into ``meshcat`` under /drakeslip (deleting what was there) and set
    its animation (``speed`` times real time, ``fps`` frames a second), as ``drakeslip.meshcat_replay.draw_replay``
    does for the SLIP; the robot's links are under /drakeslip/world/robot. ``planned_footholds``: x positions (on
    the terrain) or (x, z) pairs; ``predicted_apexes``: ApexStates or (x, z, ...) tuples. Returns the number of
    animation frames."""
    if not log.times:
        raise ValueError("the run has no trajectory to replay: run it with trajectory=True")
    model = model or RobotModel()
    scene = _scene(log, model, terrain, planned_footholds, predicted_apexes)
    root = "/drakeslip"
    shown_from = draw_scene(meshcat, scene, root, follow)
    robot = f"{root}/world/robot"
    for link, name, shape, in_link, colour in model.parts:
        meshcat.SetObject(f"{robot}/{link}/{name}", shape, colour)
        meshcat.SetTransform(f"{robot}/{link}/{name}", in_link)
    meshcat.SetTransform(robot, pose(0.0, Y_HOPPER, 0.0))
    times, positions = scene.times, model.positions(log)

    def robot_at(t):
        q = [np.interp(t, times, positions[:, i]) for i in range(positions.shape[1])]
        return {f"{robot}/{link}": x for link, x in model.poses(q).items()}, []

    return animate(meshcat, scene, robot_at, shown_from, root, fps=fps, speed=speed, follow=follow)


# many parameters: ``draw_robot_replay``'s, with the page's path, title and robot
def write_robot_replay(log: HopLog, terrain: Terrain, path, planned_footholds=None, predicted_apexes=None,
                       title: str | None = None, robot: RobotParams | None = None, *, fps: float = 30.0,
                       speed: float = 1.0, follow: bool = True) -> Path:
    """Write the HTML replay of ``log`` (positions at ``log.times``) on ``terrain`` to ``path`` (see
    ``draw_robot_replay``); returns the Path."""
    from pydrake.geometry import Meshcat

    model = RobotModel(robot)
    meshcat = Meshcat()
    try:
        draw_robot_replay(meshcat, log, terrain, planned_footholds, predicted_apexes, model, fps=fps, speed=speed,
                          follow=follow)
        failure = log.failure
        outcome = "no failure" if failure is None else \
            f"failed: {failure.mode.name} ({failure.what}) at t = {failure.time:.2f} s, x = {failure.x:.2f} m"
        summary = f"{len(log.footholds)} touchdowns, {outcome}; largest body pitch {log.max_pitch:.2f} rad"
        items = legend(_scene(log, model, terrain, planned_footholds, predicted_apexes), model.legend_items())
        return write_page(meshcat, path, title or "multibody hopper replay", summary, items, speed=speed, fps=fps)
    finally:
        del meshcat


def plot_robot_run(log: HopLog, terrain: Terrain, robot: RobotParams | None = None, ax=None):
    """The run of ``log`` (with its trajectory) drawn as ``drakeslip.viz.plot_hops`` draws a hopper's: the body's
    path, the leg from hip to foot at every touchdown and liftoff, the footholds, the apexes and the failure.
    Returns the Axes."""
    from drakeslip.viz import plot_hops

    if not log.times:
        raise ValueError("the run has no trajectory to draw: run it with trajectory=True")
    model = RobotModel(robot)
    times, positions = np.asarray(log.times), model.positions(log)

    def at(t):
        return positions[min(int(np.searchsorted(times, t)), len(times) - 1)]

    legs = [(kind, *model.hip_and_foot(at(t))) for kind, ts in (("touchdown", log.touchdown_times),
                                                                 ("liftoff", log.liftoff_times)) for t in ts]
    footholds = np.column_stack([log.footholds, terrain.height_at(np.asarray(log.footholds, dtype=float))])
    path = model.body_path(positions)
    apexes = [path[0]] + [(a.x, a.z) for a in log.apexes]
    failure = None
    if log.failure is not None:
        failure = (log.failure.state[:2], model.hip_and_foot(positions[-1])[1], log.failure.mode.name)
    outcome = f"failed ({log.failure.mode.name})" if log.failure else "ok"
    return plot_hops(terrain, path, legs, footholds, apexes, failure, ax,
                     f"multibody robot: {len(log.apexes)} apexes, {len(log.footholds)} footholds, {outcome}")
