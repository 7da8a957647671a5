"""The multibody hopper's Diagram, built by one function: plant + scene graph (robot and terrain), the
controller, and either a fixed footstep command or a planner system, with an optional Meshcat visualizer."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.systems.framework import DiagramBuilder

from drakeslip.multibody.controller import FootholdCommand, HopperController, Phase
from drakeslip.multibody.gains import RETRACT
from drakeslip.multibody.robot import HopperParts, RobotParams, StateLayout, add_hopper
from drakeslip.multibody.terrain import add_terrain
from drakeslip.state import ApexState
from drakeslip.terrain import Terrain


@dataclass
class HopperDiagram:
    """A built diagram and its parts: ``plant``, ``scene_graph``, ``controller``, ``parts`` and ``layout`` of the
    robot in the plant, ``planner`` (None with a fixed command) and ``visualizer`` (None without Meshcat)."""

    diagram: object
    plant: object
    scene_graph: object
    controller: HopperController
    parts: HopperParts
    layout: StateLayout
    params: RobotParams
    terrain: Terrain
    planner: object = None
    visualizer: object = None


def add_robot_plant(builder, time_step: float):
    """A robot's plant and scene graph in ``builder``: discrete at ``time_step``, compliant point contact solved by
    SAP (the planar and the spatial robot's)."""
    config = MultibodyPlantConfig(time_step=time_step, contact_model="point", discrete_contact_approximation="sap")
    return AddMultibodyPlant(config, builder)


def add_robot_and_terrain(builder, terrain: Terrain, params: RobotParams):
    """Add the plant (discrete at ``params.time_step``, compliant point contact solved by SAP) with the hopper
    and ``terrain``'s boxes to ``builder``; returns (plant, scene_graph, parts, layout)."""
    plant, scene_graph = add_robot_plant(builder, params.time_step)
    parts = add_hopper(plant, params)
    add_terrain(plant, terrain, params.slip.friction)
    plant.Finalize()
    return plant, scene_graph, parts, parts.layout(plant)


def build_diagram(terrain: Terrain, params: RobotParams | None = None, *, make_planner=None,
                  inject_energy: bool = True, meshcat=None, known: RobotParams | None = None) -> HopperDiagram:
    """The closed loop on ``terrain``: plant and scene graph (the robot ``params``), the controller (for the robot
    ``known``, default ``params``: under a noise profile's model mismatch the controller keeps the model's spring,
    mass and friction while the plant has the drawn ones; ``inject_energy`` as there), and
    the command from the system ``make_planner(layout)`` returns (ports ``state`` in and ``command`` out, e.g.
    ``planners.drake_system.FootstepPlannerSystem``) or, without one, from a fixed value the caller sets on the
    diagram's ``command`` input (``set_command``). ``meshcat``: a ``pydrake.geometry.Meshcat`` to draw into."""
    params = params or RobotParams()
    builder = DiagramBuilder()
    plant, scene_graph, parts, layout = add_robot_and_terrain(builder, terrain, params)
    controller = builder.AddSystem(HopperController(known or params, layout, inject_energy))
    controller.set_name("hopper_controller")
    builder.Connect(plant.get_state_output_port(), controller.state_port)
    builder.Connect(controller.get_output_port(0), plant.get_actuation_input_port())
    planner_system = None if make_planner is None else make_planner(layout)
    visualizer = command_and_view(builder, plant, scene_graph, controller.command_port, planner_system, meshcat)
    return HopperDiagram(builder.Build(), plant, scene_graph, controller, parts, layout, params, terrain,
                         planner_system, visualizer)


def command_and_view(builder, plant, scene_graph, command_port, planner_system=None, meshcat=None):
    """Feed the controller's ``command_port`` from ``planner_system`` (added to ``builder``, its ``state`` input
    on the plant's state, its ``command`` output on the port) or, without one, export the port as the diagram's
    ``command`` input; with a ``pydrake.geometry.Meshcat``, draw ``scene_graph``'s illustration into it. Returns the
    visualizer (None without Meshcat). The planar and the spatial robot's diagrams are wired by it."""
    if planner_system is not None:
        builder.AddSystem(planner_system)
        builder.Connect(plant.get_state_output_port(), planner_system.GetInputPort("state"))
        builder.Connect(planner_system.GetOutputPort("command"), command_port)
    else:
        builder.ExportInput(command_port, "command")
    if meshcat is None:
        return None
    from pydrake.geometry import MeshcatVisualizer, MeshcatVisualizerParams, Role

    return MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat,
                                          MeshcatVisualizerParams(role=Role.kIllustration))


def set_apex_state(hd: HopperDiagram, root_context, apex: ApexState, leg_angle: float = 0.0,
                   energy_bias: float = 0.0) -> None:
    """Put the robot at ``apex`` (body level and still in pitch, moving at xdot), its leg retracted as in
    flight at the absolute ``leg_angle``, and the controller in its descent phase with ``energy_bias``."""
    p = hd.params
    plant_context = hd.plant.GetMyMutableContextFromRoot(root_context)
    q = np.zeros(hd.plant.num_positions())
    v = np.zeros(hd.plant.num_velocities())
    nq = hd.plant.num_positions()
    q[list(hd.layout.q)] = (apex.x, apex.z, 0.0, leg_angle, p.rest_extension - RETRACT)
    v[[i - nq for i in hd.layout.v]] = (apex.xdot, 0.0, 0.0, 0.0, 0.0)
    hd.plant.SetPositions(plant_context, q)
    hd.plant.SetVelocities(plant_context, v)
    controller_context = hd.controller.GetMyMutableContextFromRoot(root_context)
    controller_context.SetDiscreteState(hd.controller.initial_state(Phase.DESCENT, energy_bias))


def set_command(hd: HopperDiagram, root_context, command: FootholdCommand) -> None:
    """Fix the command of a diagram built without a planner system."""
    hd.diagram.GetInputPort("command").FixValue(root_context, command)
