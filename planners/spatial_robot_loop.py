"""The receding-horizon loop on a height map on the spatial multibody robot: the map loop (``planners.spatial_loop``)
as a planner system in the robot's Diagram.

``MapPlannerSystem`` is an ``ApexPlannerSystem`` (``planners.drake_system``) whose planning call at each of the robot's
apexes asks the case's ``MapLoop`` for the next foothold (planning on the window ahead when its queue is empty, flying
on along the last plan, then safe hops, as on the template's backends) and outputs it as a ``SpatialCommand`` with the
window the loop planned on; the robot's controller (``drakeslip.spatial.multibody.controller``) aims its foot at it from
the state it measures, keeping the apex's energy as the template does, and lifts the foot clear of that map before
swinging it forward. Two things differ from the template's loop, because the robot is not where the template would be:
it flies a plan's next foothold (or on along its last plan) only where the template's hop from the apex it reached still
lands there, else it plans again; and where the loop has no plan and no hop of one it hops in place (Raibert's placement
to a standstill), up to IN_PLACE_HOPS in a row, and asks again. The loop is the system's state: a value replaced at each
apex, never changed in place. ``run_map_case_on_robot`` runs one case as one Diagram (plant, planner system,
controller), ending at the apex after the hop that passes the goal, a failure of the robot (the monitor's names,
``drakeslip.spatial.multibody.gait``), no plan or the hop cap.

The planners plan for the hopper's own SLIP (or ``config.template``, e.g. the SLIP fitted to the robot,
``drakeslip.spatial.multibody.fit``) with PLANNED_FRICTION_SHARE of the ground's friction. Under a noise profile the
plant is the robot of the case's drawn spring, mass and friction while the controller keeps the model's, and the
planner is told the apex and sees the map with their errors (the map loop's draws); the controller aims from the
state it measures.
"""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass

import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import EventStatus

from drakeslip.params import SlipParams
from drakeslip.simulation import advance
from drakeslip.spatial.multibody.controller import SpatialCommand
from drakeslip.spatial.multibody.diagram import build_spatial_diagram, set_apex_state
from drakeslip.spatial.multibody.gait import LOSS_PRIOR, SpatialMonitor, leg_toward
from drakeslip.spatial.multibody.robot import SpatialLayout, SpatialRobotParams
from drakeslip.units import units_of

from planners.drake_system import ApexPlannerSystem
from planners.replanning import ClosedLoopConfig
from planners.spatial_loop import MapCase, MapLoop, map_case_result


IN_PLACE_HOPS = 3   # hops in place in a row, at most, before "no plan" ends the run
# The robot's planners plan for the hopper's SLIP with this share of the ground's friction: the robot's hip spends up
# to FRICTION_SHARE of the friction its leg leaves on the body's attitude and its foot lands moving, so a hop the
# template makes at the edge of the friction cone slides on the robot
PLANNED_FRICTION_SHARE = 0.7


@dataclass(frozen=True)
class LoopState:
    """The planner system's log: the case's ``MapLoop`` after the last planning call. The system replaces it at each
    apex with a changed copy (``MapLoop.copy``), so the copies of a Context Drake makes may share it."""

    loop: MapLoop
    in_place: int = 0   # hops in place in a row, from apexes with no plan

    def __deepcopy__(self, memo):
        return self


class MapPlannerSystem(ApexPlannerSystem):
    """The map loop at the spatial robot's apexes (see the module doc).

    Input port
      state: the plant's state vector, read through ``layout``.
    Output port
      command: abstract ``SpatialCommand`` (stamp -1 before the first apex; each apex's stamp is the last's + 1).
    State
      discrete (``ApexWatch``): rising, apexes_since_plan.
      abstract: the command; the ``LoopState``.
    Parameters
      ``loop`` (the case's ``MapLoop``: planner, map, goal, template, noise), ``layout`` (the robot in the plant),
      ``time_step`` (how often it checks for an apex).
    """

    def __init__(self, loop: MapLoop, layout: SpatialLayout, *, time_step: float = 1e-3):
        self.layout = layout
        super().__init__(layout.size, layout.linear[2], SpatialCommand(stamp=-1), LoopState(loop),
                         time_step=time_step, replan_every=1)

    def loop(self, context) -> MapLoop:
        """The case's loop in the system's ``context``."""
        return self.log(context).loop

    def plan_at(self, state: np.ndarray, stamp: int, log: LoopState) -> tuple:
        lay = self.layout
        x, y, z = (float(state[i]) for i in lay.position)
        vx, vy = (float(state[i]) for i in lay.linear[:2])
        loop = log.loop.copy()
        target = loop.next_foothold((x, y, z, vx, vy))
        velocity = (vx, vy)
        if loop.failure == "NO_PLAN" and log.in_place < IN_PLACE_HOPS:
            # no plan and no hop of one: the robot hops in place (Raibert's placement to a standstill) and plans
            # again from the apex after, where a slower start may have one
            loop.failure, velocity = None, (0.0, 0.0)
            loop.plans[-1]["in_place"] = True
            return (SpatialCommand((), apex_height=z, stamp=stamp, velocity=velocity, height_map=loop.window),
                    LoopState(loop, log.in_place + 1))
        footholds = () if target is None else (tuple(float(v) for v in target),)
        # past the loop's end the robot hops on as it goes, Raibert's placement keeping its velocity
        return (SpatialCommand(footholds, apex_height=z, stamp=stamp, velocity=velocity, height_map=loop.window),
                LoopState(loop))


class LoopMonitor(SpatialMonitor):
    """``SpatialMonitor`` that ends the run at the first apex after the loop's last hop (the one passing the goal,
    outcome "goal") and where the loop ends without one (its failure: NO_PLAN, HOP_CAP, UNREACHABLE)."""

    def __init__(self, sd, root_context, planner: MapPlannerSystem, done_at_start: bool, trajectory: bool = False):
        super().__init__(sd, root_context, pause_at_apexes=False, trajectory=trajectory)
        self.planner, self.outcome = planner, "running"
        self.planner_context = planner.GetMyContextFromRoot(root_context)
        self.done_at = 0 if done_at_start else None   # apexes logged when the loop commanded its last hop

    def __call__(self, root_context):
        status = super().__call__(root_context)
        if self.log.failure is not None:
            self.outcome = self.log.failure.mode.name
            return status
        loop = self.planner.loop(self.planner_context)
        if loop.done and self.done_at is None:
            self.done_at = len(self.log.apexes)
        if loop.failure is not None:
            self.outcome = loop.failure
        elif self.done_at is not None and len(self.log.apexes) > self.done_at:
            self.outcome = "goal"   # the apex after the hop that passes the goal
        else:
            return status
        return EventStatus.ReachedTermination(self.sd.diagram, self.outcome)


def run_map_case_on_robot(planner, case: MapCase, params: SlipParams, config: ClosedLoopConfig,
                          robot: SpatialRobotParams | None = None, meshcat=None, trajectory: bool = False) -> dict:
    """One case on a height map on the spatial robot ``robot`` (default: ``config.robot``, else the robot of the
    hopper ``params``, ``SpatialRobotParams.for_hopper``), the planner planning for ``params``. Returns the case's
    result as ``planners.spatial_loop.run_map_case`` writes it, with the robot's "what", "hops", "max_roll",
    "max_pitch", "simulated_s" and "wall_s"; with ``trajectory``, also "log" (the run's ``GaitLog`` with its
    trajectory) and "robot" (the ``SpatialRobotParams`` that ran)."""
    template = config.template or params   # the SLIP the planners plan for, with the case's friction share
    loop = MapLoop(planner, case, params, config, checks_flying_on=True,
                   plans_for=template.with_friction(PLANNED_FRICTION_SHARE * params.friction))
    model = robot or config.robot or SpatialRobotParams.for_hopper(params)
    plant_robot = model.with_slip(loop.executed)   # under noise, the drawn spring, mass and friction

    def make_planner(layout: SpatialLayout) -> MapPlannerSystem:
        system = MapPlannerSystem(loop, layout, time_step=model.time_step)
        system.set_name("map_planner")
        return system

    sd = build_spatial_diagram(case.terrain, plant_robot, known=model, make_planner=make_planner, meshcat=meshcat)
    simulator = Simulator(sd.diagram)
    context = simulator.get_mutable_context()
    apex = tuple(float(v) for v in case.apex)
    set_apex_state(sd, context, apex[:3], apex[3:5], energy_bias=LOSS_PRIOR * units_of(model.slip).speed ** 2)
    # the first planning call is made before the start, so that the leg starts aimed at its first foothold
    planner_context = sd.planner.GetMyMutableContextFromRoot(context)
    first = sd.planner.start_at(planner_context, sd.plant.GetPositionsAndVelocities(
        sd.plant.GetMyContextFromRoot(context)))
    if first.footholds:
        set_apex_state(sd, context, apex[:3], apex[3:5], leg_toward(apex, first.footholds[0], model),
                       LOSS_PRIOR * units_of(model.slip).speed ** 2)
    monitor = LoopMonitor(sd, context, sd.planner, sd.planner.loop(planner_context).done, trajectory)
    simulator.set_monitor(monitor)
    if sd.visualizer is not None:
        sd.visualizer.StartRecording()
    start = time.perf_counter()
    advance(simulator, monitor.hop_seconds * (config.max_hops + 2),
            lambda: f"the spatial robot's hop {len(monitor.log.touchdowns)}")
    wall = time.perf_counter() - start
    if sd.visualizer is not None:
        sd.visualizer.StopRecording()
        sd.visualizer.PublishRecording()
    log = monitor.log
    final = log.apexes[-1][1:3] if log.apexes else apex[:2]
    failure = None if monitor.outcome == "goal" else (
        monitor.outcome if monitor.outcome != "running" else "STOPPED_SHORT")
    loop = sd.planner.loop(sd.planner.GetMyContextFromRoot(context))
    reached = [t[1:4] for t in log.touchdowns]
    result = map_case_result(loop, case, failure, final, reached)
    roll, pitch = log.max_attitude()
    result.update(what=log.failure.what if log.failure else monitor.outcome, hops=len(log.touchdowns),
                  max_roll=roll, max_pitch=pitch, simulated_s=context.get_time(), wall_s=wall)
    result["planned_for"] = asdict(loop.plans_for)
    if not loop.noise.silent:
        result["executed_robot"] = asdict(plant_robot)
    if trajectory:
        result.update(log=log, robot=plant_robot)
    return result
