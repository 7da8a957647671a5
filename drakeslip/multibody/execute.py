"""Footsteps executed on the multibody hopper from an apex, recorded as a ``HopLog`` (``drakeslip.rollout``'s
multibody backend turns it into the project's ``Rollout``, so that plan checking and robustness run on the
robot), and the flat-ground gait check."""
from __future__ import annotations

import math

import numpy as np
from pydrake.systems.analysis import Simulator

from drakeslip.multibody.controller import FootholdCommand, apex_energy
from drakeslip.multibody.diagram import build_diagram, set_apex_state, set_command
from drakeslip.multibody.failures import HopLog, HopMonitor
from drakeslip.multibody.robot import RobotParams
from drakeslip.params import SlipParams
from drakeslip.simulation import advance
from drakeslip.state import ApexState
from drakeslip.terrain import Terrain
from drakeslip.units import units_of

# The energy per kg of body a hop of the paper's hopper loses beyond the foot's liftoff (which the controller
# accounts for), a + b xdot^2 [J/kg]: the controller starts from this estimate and keeps learning from each apex.
LOSS_PRIOR = (0.10, 0.035)

# The last diagram built, as (terrain, (robot, inject_energy, known), diagram): the terrain is held and compared by
# identity (a map's cells are not compared at every call), the settings by value.
_last_built: list = []


def _diagram(terrain: Terrain, robot: RobotParams, inject_energy: bool, known: RobotParams | None = None):
    """The diagram for this terrain and robot, reused while they stay the same (building one takes ~0.1 s)."""
    settings = (robot, inject_energy, known)
    if not (_last_built and _last_built[0][0] is terrain and _last_built[0][1] == settings):
        _last_built[:] = [(terrain, settings, build_diagram(terrain, robot, inject_energy=inject_energy, known=known))]
    return _last_built[0][2]


def loss_prior(xdot: float, slip: SlipParams) -> float:
    """The hop's loss estimate (``LOSS_PRIOR``) for the hopper ``slip``: ``a`` an energy per kg, in its speed units
    squared."""
    a, b = LOSS_PRIOR
    return a * units_of(slip).speed ** 2 + b * xdot * xdot


# many parameters: the hops, then ``drakeslip.rollout``'s errors and options as keywords, each with a default
def execute(apex, terrain: Terrain, footholds, robot: RobotParams | None = None, *,
            sensed_terrain: Terrain | None = None, apex_errors=None, angle_errors=None, inject_energy: bool = True,
            trajectory: bool = False, max_time: float | None = None, known: RobotParams | None = None) -> HopLog:
    """Hop the robot from ``apex`` (body level, leg retracted and aimed at the first foothold) over ``terrain``,
    touching down on each of ``footholds`` (aimed at on ``sensed_terrain``, default ``terrain``) and stopping at
    the apex after the last. ``apex_errors`` (per hop, (x, z, xdot)) and ``angle_errors`` (per hop, rad) as in
    ``drakeslip.rollout``. Returns the HopLog: footholds touched, absolute leg angles at touchdown, apexes, the
    named failure (a STALL when the hops do not finish in time), the largest pitch, the trajectory when asked.
    ``known``: the robot its controller is built for (default ``robot``; a noise profile's model mismatch runs a
    ``robot`` whose spring, mass and friction differ from the ``known`` model's)."""
    robot = robot or RobotParams()
    apex = ApexState(*map(float, apex))
    footholds = tuple(float(f) for f in footholds)
    hd = _diagram(terrain, robot, inject_energy, known)
    simulator = Simulator(hd.diagram)
    context = simulator.get_mutable_context()
    errors = () if apex_errors is None else tuple(tuple(map(float, e)) for e in np.asarray(apex_errors))
    command = FootholdCommand(footholds, sensed_terrain or terrain, None, 0, 0.0, errors,
                              () if angle_errors is None else tuple(map(float, np.ravel(angle_errors))))
    set_apex_state(hd, context, apex, _first_angle(apex, footholds, command.terrain, robot),
                   loss_prior(apex.xdot, robot.slip))
    set_command(hd, context, command)
    monitor = HopMonitor(hd, terrain, context, len(footholds), trajectory)
    monitor.command_footholds = footholds
    simulator.set_monitor(monitor)
    end = max_time if max_time is not None else monitor.hop_seconds * (len(footholds) + 1)
    advance(simulator, end, lambda: f"the robot's hop {len(monitor.log.footholds)}")
    log = monitor.log
    if log.failure is None and len(log.apexes) < len(footholds):
        from drakeslip.multibody.failures import RobotFailure
        from drakeslip.state import FailureMode

        x = float(log.apexes[-1].x) if log.apexes else apex.x
        log.failure = RobotFailure(FailureMode.STALL, "the hops did not finish in time", end, x, len(log.footholds),
                                   (x, math.nan, math.nan, math.nan))
    return log


def hop_at_speed(speed: float, hops: int, robot: RobotParams | None = None, apex_height: float = 0.62,
                 trajectory: bool = False) -> HopLog:
    """``hops`` hops on flat ground at the forward ``speed`` (0: in place) with the controller's own foot
    placement (Raibert's) and an energy target of an apex ``apex_height`` high at that speed: the gait check."""
    robot = robot or RobotParams()
    terrain = Terrain.flat(length=max(30.0, 1.5 * hops * max(speed, 0.1)))
    hd = _diagram(terrain, robot, True)
    simulator = Simulator(hd.diagram)
    context = simulator.get_mutable_context()
    apex = ApexState(0.0, apex_height, float(speed))
    command = FootholdCommand((), terrain, apex_energy(apex_height, speed, robot.slip.gravity), 0, float(speed))
    set_apex_state(hd, context, apex, hd.controller.raibert_angle(speed, speed), loss_prior(speed, robot.slip))
    set_command(hd, context, command)
    monitor = HopMonitor(hd, terrain, context, hops, trajectory)
    simulator.set_monitor(monitor)
    advance(simulator, monitor.hop_seconds * (hops + 1), lambda: f"the robot's hop {len(monitor.log.footholds)}")
    return monitor.log


def _first_angle(apex: ApexState, footholds, terrain: Terrain, robot: RobotParams) -> float:
    from drakeslip.multibody.controller import HeldLeg, touchdown_angle

    if not footholds:
        return 0.0
    leg = HeldLeg(robot.rest_extension, robot.foot_radius, robot.slip.gravity)
    return touchdown_angle(apex.x, apex.z, apex.xdot, 0.0, footholds[0], terrain.height_at(footholds[0]), leg)
