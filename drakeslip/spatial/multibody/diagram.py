"""The spatial hopper's Diagram, built by one function: plant + scene graph (robot and height map), the controller,
and either the command on an exported input or a planner system, with an optional Meshcat visualizer."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.systems.framework import DiagramBuilder

from drakeslip.multibody.controller import Phase
from drakeslip.multibody.diagram import add_robot_plant, command_and_view
from drakeslip.spatial.heightmap import HeightMap
from drakeslip.spatial.multibody.aiming import hip_angles
from drakeslip.spatial.multibody.controller import SpatialCommand, SpatialHopperController
from drakeslip.spatial.multibody.robot import (SpatialHopperParts, SpatialLayout, SpatialRobotParams,
                                               add_spatial_hopper)
from drakeslip.spatial.multibody.terrain import add_height_map


@dataclass
class SpatialHopperDiagram:
    """A built diagram and its parts: ``plant``, ``scene_graph``, ``controller``, ``parts`` and ``layout`` of the
    robot in the plant, the robot ``params``, the ``height_map``, ``planner`` (None with the command exported) and
    ``visualizer`` (None without Meshcat)."""

    diagram: object
    plant: object
    scene_graph: object
    controller: SpatialHopperController
    parts: SpatialHopperParts
    layout: SpatialLayout
    params: SpatialRobotParams
    height_map: HeightMap
    planner: object = None
    visualizer: object = None


def build_spatial_diagram(height_map: HeightMap, params: SpatialRobotParams | None = None, *, make_planner=None,
                          known: SpatialRobotParams | None = None, meshcat=None) -> SpatialHopperDiagram:
    """The robot ``params`` (default the paper's hopper's) on ``height_map``: the plant (discrete at the robot's
    time step, compliant point contact solved by SAP) with the map's boxes; the controller, for the robot ``known``
    (default ``params``: under a noise profile's model mismatch the plant has the drawn spring, mass and friction);
    and the command from the system ``make_planner(layout)`` returns (ports ``state`` in, ``command`` out, e.g.
    ``planners.spatial_robot_loop.MapPlannerSystem``) or, without one, on the diagram's exported ``command`` input
    (``set_command``). ``meshcat``: a ``pydrake.geometry.Meshcat`` to draw into."""
    params = params or SpatialRobotParams()
    builder = DiagramBuilder()
    plant, scene_graph = add_robot_plant(builder, params.time_step)
    parts = add_spatial_hopper(plant, params)
    add_height_map(plant, height_map, params.slip.friction)
    plant.Finalize()
    layout = parts.layout(plant)
    controller = builder.AddSystem(SpatialHopperController(known or params, layout))
    controller.set_name("spatial_hopper_controller")
    builder.Connect(plant.get_state_output_port(), controller.state_port)
    builder.Connect(controller.get_output_port(0), plant.get_actuation_input_port())
    planner = None if make_planner is None else make_planner(layout)
    visualizer = command_and_view(builder, plant, scene_graph, controller.command_port, planner, meshcat)
    return SpatialHopperDiagram(builder.Build(), plant, scene_graph, controller, parts, layout, params, height_map,
                                planner, visualizer)


def set_apex_state(sd: SpatialHopperDiagram, root_context, position, velocity, leg_direction=(0.0, 0.0, -1.0),
                   energy_bias: float = 0.0) -> None:
    """Put the robot at an apex: body level, facing +x, at ``position`` moving at ``velocity`` (vx, vy), its leg
    retracted as in flight along the world ``leg_direction``, the controller in its descent with ``energy_bias``."""
    plant_context = sd.plant.GetMyMutableContextFromRoot(root_context)
    lay = sd.layout
    x = np.zeros(lay.size)
    x[list(lay.quaternion)] = (1.0, 0.0, 0.0, 0.0)
    x[list(lay.position)] = position
    x[list(lay.hip)] = hip_angles(np.asarray(leg_direction, dtype=float))
    x[lay.leg] = sd.params.rest_extension - sd.controller.scaled.retract
    x[list(lay.linear)] = (velocity[0], velocity[1], 0.0)
    sd.plant.SetPositionsAndVelocities(plant_context, x)
    controller_context = sd.controller.GetMyMutableContextFromRoot(root_context)
    controller_context.SetDiscreteState(sd.controller.initial_state(Phase.DESCENT, energy_bias))


def set_command(sd: SpatialHopperDiagram, root_context, command: SpatialCommand) -> None:
    """Fix the diagram's ``command`` input."""
    sd.diagram.GetInputPort("command").FixValue(root_context, command)
