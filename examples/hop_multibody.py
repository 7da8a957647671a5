"""The footstep planner and the hopper's controller as Drake systems wired into a Diagram of your own.

    python3 examples/hop_multibody.py --planner step@robust --goal 4 --html out/hop_multibody.html

Builds, by hand, what ``planners.drake_system.build_closed_loop`` builds in one call: a MultibodyPlant with the
hopper (``drakeslip/multibody/robot.sdf``) and a terrain's boxes, the ``HopperController``, and the
``FootstepPlannerSystem`` (any registered planner label), connected as

    plant.state -> planner.state, controller.state;  planner.command -> controller.command;
    controller.actuation -> plant.actuation

then runs the Diagram in one Simulator from an apex until the body passes the goal, and prints each plan the
planner made at an apex. Add your own systems (an estimator, a logger, a visualizer) the same way. Exit status
0 when the body reaches the goal, 1 otherwise, 2 on bad input, 3 a simulation crashed (one line naming what
failed: drakeslip/jobs/cli.py).
"""
from __future__ import annotations

import sys

from drakeslip.jobs import cli
from drakeslip import cli_physics

OK, FAILED = cli.OK, cli.FAILED


def two_ditches():
    """Flat ground with 0.4 m ditches at x = 1.5-1.9 m and 3.0-3.4 m."""
    import numpy as np

    from drakeslip import Terrain

    heights = np.zeros(120)
    heights[45:49] = heights[60:64] = -1.0
    return Terrain(heights, 0.1, -3.0)


def build(planner: str, terrain, goal_x: float, meshcat=None):
    """(diagram, plant, controller, planner system): the closed loop wired by hand."""
    from pydrake.systems.framework import DiagramBuilder

    from drakeslip import SlipParams
    from drakeslip.multibody.controller import HopperController
    from drakeslip.multibody.diagram import add_robot_and_terrain
    from drakeslip.multibody.pump import EnergyPump
    from drakeslip.multibody.robot import RobotParams
    from planners.drake_system import FootstepPlannerSystem
    from planners.replanning import Replanner

    robot = RobotParams()
    builder = DiagramBuilder()
    plant, scene_graph, _, layout = add_robot_and_terrain(builder, terrain, robot)
    controller = builder.AddSystem(HopperController(robot, layout))
    replanner = Replanner(planner, terrain, goal_x, SlipParams(), face_keep_out=robot.face_keep_out)
    planner_system = builder.AddSystem(FootstepPlannerSystem(replanner, layout, time_step=robot.time_step,
                                                             pump=EnergyPump.for_robot(robot, SlipParams())))
    builder.Connect(plant.get_state_output_port(), planner_system.GetInputPort("state"))
    builder.Connect(plant.get_state_output_port(), controller.GetInputPort("state"))
    builder.Connect(planner_system.GetOutputPort("command"), controller.GetInputPort("command"))
    builder.Connect(controller.GetOutputPort("actuation"), plant.get_actuation_input_port())
    if meshcat is not None:
        from pydrake.geometry import MeshcatVisualizer

        MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat)
    return builder.Build(), plant, controller, planner_system


def run(planner: str, goal_x: float, start=(0.0, 0.62, 1.5), seconds: float = 6.0, meshcat=None):
    """Simulate the hand-built diagram from the apex ``start`` until the body's x passes ``goal_x`` (or
    ``seconds``); returns (the planner system's records, one per plan, the final body x, the simulated time, the
    apexes the controller counted)."""
    import numpy as np
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import EventStatus

    from drakeslip.multibody.controller import Phase
    from drakeslip.multibody.gains import RETRACT

    diagram, plant, controller, planner_system = build(planner, two_ditches(), goal_x, meshcat)
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    q = np.array([start[0], start[1], 0.0, 0.0, controller.params.rest_extension - RETRACT])
    plant.SetPositions(plant_context, q)
    plant.SetVelocities(plant_context, np.array([start[2], 0.0, 0.0, 0.0, 0.0]))
    controller.GetMyMutableContextFromRoot(context).SetDiscreteState(controller.initial_state(Phase.DESCENT))
    state = plant.get_state_output_port()

    def past_goal(root_context):
        x = state.Eval(plant_context)[0]
        return EventStatus.ReachedTermination(diagram, "goal") if x >= goal_x else EventStatus.Succeeded()

    simulator.set_monitor(past_goal)
    if meshcat is not None:
        meshcat.StartRecording()
    simulator.AdvanceTo(seconds)
    apexes = controller.control_state_of(controller.GetMyContextFromRoot(context)).apexes
    records = planner_system.records(planner_system.GetMyContextFromRoot(context))
    return records, float(state.Eval(plant_context)[0]), context.get_time(), int(apexes)


@cli_physics.reports_crashes
def main(argv=None) -> int:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--planner", default="step@robust", help="a registered planner label")
    ap.add_argument("--goal", type=cli.number(2.0, 8.0), default=4.0,
                    help="goal x [m] (ditches at 1.5-1.9 and 3.0-3.4 m)")
    ap.add_argument("--html", type=cli.output_file(".html"), default=None,
                    help="also write a Meshcat replay of the run here (.html)")
    args = ap.parse_args(argv)
    import planners

    try:
        planners.registry.check_label(args.planner)
    except ValueError as error:
        ap.error(str(error))
    meshcat = None
    if args.html:
        from pydrake.geometry import Meshcat

        meshcat = Meshcat()
    records, x, seconds, _ = run(args.planner, args.goal, meshcat=meshcat)
    for record in records:
        print(f"apex x={record['apex'][0]:.2f} z={record['apex'][1]:.2f} xdot={record['apex'][2]:.2f}: "
              f"{'plan' if record['success'] else 'no plan'}, next footholds {record['footholds'][:3]}")
    print(f"body at x={x:.2f} m after {seconds:.1f} s simulated; goal {args.goal} m")
    if meshcat is not None:
        meshcat.StopRecording()
        meshcat.PublishRecording()
        with open(args.html, "w") as f:
            f.write(meshcat.StaticHtml())
        print(f"wrote {args.html}")
    return OK if x >= args.goal else FAILED


if __name__ == "__main__":
    sys.exit(main())
