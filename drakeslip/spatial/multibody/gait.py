"""What a run of the spatial robot did, apex by apex, and how it failed; the flat-ground gait runs (at a velocity,
a turn, a push).

``SpatialMonitor`` is a Simulator monitor that reads the plant's state and the controller's phase after every step
and stops the run at each apex (so the caller can change the command or push the robot) and at a failure. Failures
carry the SLIP's names (``FailureMode``) with what happened (``RobotFailure.what``): BODY_COLLISION — a fall, the body
rolled or pitched past ``PITCH_LIMIT`` or its box reaching the ground; FOOT_COLLISION — the foot pressed into a face or
into a hole; SLIP — the foot sliding ``SLIP_DISTANCE`` in stance beyond the ball's rolling; BOTTOM_OUT — the leg at
its bottom-out stop; STALL — a phase longer than the template's ``hop_seconds``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import EventStatus

from drakeslip.multibody.controller import Phase
from drakeslip.multibody.execute import LOSS_PRIOR as PLANAR_LOSS_PRIOR
from drakeslip.multibody.failures import PITCH_LIMIT, SLIP_DISTANCE, RobotFailure
from drakeslip.simulation import advance
from drakeslip.spatial.heightmap import HeightMap, ScalarHeights
from drakeslip.spatial.multibody.aiming import aim_direction, roll_pitch_yaw, rotation
from drakeslip.spatial.multibody.controller import SpatialCommand
from drakeslip.spatial.multibody.diagram import build_spatial_diagram, set_apex_state, set_command
from drakeslip.spatial.multibody.robot import SpatialRobotParams, leg_direction, spatial_geometry
from drakeslip.state import FailureMode
from drakeslip.units import units_of

# [J/kg] what a hop of the paper's hopper in place loses beyond the foot's liftoff (the planar robot's estimate, in a
# hopper's units): the energy bias the controller starts from and keeps learning
LOSS_PRIOR = PLANAR_LOSS_PRIOR[0]
APEX_HEIGHT = 0.62   # [m] the gait's apex above flat ground, the paper's hopper's (in a hopper's lengths)
TRAJECTORY_STEP = 1.0 / 240.0   # [s] a logged trajectory's sampling (the paper's hopper's time): replays play at 30 fps
CORNERS = np.array([(u, v, w) for u in (-1, 1) for v in (-1, 1) for w in (-1, 1)], dtype=float)


class BodyPose(NamedTuple):
    """The robot at a step as the monitor reads it: the body's ``position`` and ``rotation``, its ``roll`` and
    ``pitch`` (Drake's angles), the foot ball's centre ``foot``, the leg's unit ``direction`` and ``extension``."""

    position: np.ndarray
    rotation: np.ndarray
    roll: float
    pitch: float
    foot: np.ndarray
    direction: np.ndarray
    extension: float


@dataclass
class GaitLog:
    """Apexes (t, x, y, z, vx, vy, yaw) and touchdowns (t, x, y, z of the foot's contact) of a run, the largest
    |roll| and |pitch| of the body over each hop (to its apex), and the failure (None if none); for a run logged
    with its trajectory, the plant's positions at ``times`` (every TRAJECTORY_STEP of the hopper's time)."""

    apexes: list = field(default_factory=list)
    touchdowns: list = field(default_factory=list)
    hop_roll: list = field(default_factory=list)
    hop_pitch: list = field(default_factory=list)
    failure: RobotFailure | None = None
    speed_unit: float = 1.0   # the hopper's speed unit (``drakeslip.units``): tolerances scale with it
    times: list = field(default_factory=list)
    positions: list = field(default_factory=list)

    def max_attitude(self, after: int = 0) -> tuple:
        """The largest |roll| and |pitch| over the hops from the ``after``-th on."""
        return max(self.hop_roll[after:], default=0.0), max(self.hop_pitch[after:], default=0.0)


class SpatialMonitor:
    """A ``Simulator.set_monitor`` callback over a ``SpatialHopperDiagram``: logs the run into ``log`` (with its
    trajectory where ``trajectory``), ends it at a failure and, with ``pause_at_apexes``, pauses it at each apex
    (``at_apex`` turns True; the caller resets it)."""

    def __init__(self, sd, root_context, pause_at_apexes: bool = True, trajectory: bool = False):
        self.sd, self.pause_at_apexes = sd, pause_at_apexes
        self.logged_every = TRAJECTORY_STEP * units_of(sd.params.slip).time if trajectory else None
        self.plant_context = sd.plant.GetMyContextFromRoot(root_context)
        self.controller_context = sd.controller.GetMyContextFromRoot(root_context)
        self.log = GaitLog(speed_unit=units_of(sd.params.slip).speed)
        self.phase, self.phase_start, self.at_apex = None, 0.0, False
        self.roll = self.pitch = 0.0
        self.touchdown = None
        p = sd.params
        self.length = units_of(p.slip).length
        self.hop_seconds = units_of(p.slip).hop_seconds
        self.ground = ScalarHeights(sd.height_map)
        self.lowest = float(np.nanmin(sd.height_map.heights))
        self.highest = float(np.nanmax(sd.height_map.heights))
        self.body_half = np.array(spatial_geometry(p).body_half)

    def __call__(self, root_context):
        t = root_context.get_time()
        lay, p = self.sd.layout, self.sd.params
        x = self.sd.plant.get_state_output_port().Eval(self.plant_context)
        r = rotation(*x[list(lay.quaternion)])
        position, velocity = x[list(lay.position)], x[list(lay.linear)]
        roll, pitch, yaw = roll_pitch_yaw(r)
        self.roll, self.pitch = max(self.roll, abs(roll)), max(self.pitch, abs(pitch))
        d = r @ leg_direction(*x[list(lay.hip)])
        foot = position + x[lay.leg] * d
        c = self.sd.controller.control_state_of(self.controller_context)
        phase = Phase(int(c.phase))
        log = self.log
        if self.logged_every is not None and (not log.times or t >= log.times[-1] + self.logged_every):
            log.times.append(t)
            log.positions.append(self.sd.plant.GetPositions(self.plant_context).copy())
        if phase != self.phase:
            if phase == Phase.STANCE:
                contact = foot - (0.0, 0.0, p.foot_radius)
                log.touchdowns.append((t, *map(float, contact)))
                self.touchdown = (foot.copy(), d.copy())
            elif phase == Phase.DESCENT and self.phase == Phase.ASCENT:
                log.apexes.append((t, *map(float, position), float(velocity[0]), float(velocity[1]), yaw))
                log.hop_roll.append(self.roll)
                log.hop_pitch.append(self.pitch)
                self.roll = self.pitch = 0.0
                self.at_apex = True
            self.phase, self.phase_start = phase, t
        failure = self._failure(t, BodyPose(position, r, roll, pitch, foot, d, x[lay.leg]), phase)
        if failure is not None:
            log.failure = RobotFailure(failure[0], failure[1], t, float(position[0]), len(log.touchdowns),
                                       (*map(float, position), *map(float, velocity)))
            return EventStatus.ReachedTermination(self.sd.diagram, f"{failure[0].name}: {failure[1]}")
        if self.at_apex and self.pause_at_apexes:
            return EventStatus.ReachedTermination(self.sd.diagram, "apex")
        return EventStatus.Succeeded()

    def _failure(self, t, pose: BodyPose, phase: Phase):
        """The failure this step shows (mode, what), or None."""
        p = self.sd.params
        position, r, roll, pitch, foot, d, leg = pose
        if max(abs(roll), abs(pitch)) > PITCH_LIMIT:
            return FailureMode.BODY_COLLISION, f"fall: the body rolled {roll:+.2f} rad, pitched {pitch:+.2f} rad"
        corners = position + (CORNERS * self.body_half) @ r.T
        low = int(np.argmin(corners[:, 2]))
        if corners[low, 2] < self.highest:
            for point in corners:
                ground = self.ground(point[0], point[1])
                if not math.isnan(ground) and point[2] < ground:
                    return FailureMode.BODY_COLLISION, f"fall: the body touched the ground at ({point[0]:.2f}, " \
                                                       f"{point[1]:.2f})"
        if leg <= p.bottom_extension + 1e-3 * self.length:
            return FailureMode.BOTTOM_OUT, "the leg reached its bottom-out stop"
        ground = self.ground(foot[0], foot[1])
        bottom = foot[2] - p.foot_radius
        if math.isnan(ground) and bottom < self.lowest - 0.05 * self.length:
            return FailureMode.FOOT_COLLISION, f"the foot went into a hole at ({foot[0]:.2f}, {foot[1]:.2f})"
        if not math.isnan(ground) and bottom < ground - 0.01 * self.length:
            return FailureMode.FOOT_COLLISION, f"the foot pressed into a face at ({foot[0]:.2f}, {foot[1]:.2f})"
        if phase == Phase.STANCE and self.touchdown is not None:
            start, d0 = self.touchdown
            # the ball rolls as the leg turns over it: its centre moves r times the turn with no slip
            turn = math.acos(max(-1.0, min(1.0, float(d @ d0))))
            slide = math.hypot(*(foot - start)[:2]) - p.foot_radius * turn
            if slide > SLIP_DISTANCE * self.length:
                return FailureMode.SLIP, f"the foot slid {slide:.3f} m in stance"
        if t - self.phase_start > self.hop_seconds:
            return FailureMode.STALL, "no hop completed"
        return None


def hop_flat(velocities, hops: int, params: SpatialRobotParams | None = None, pushes: dict | None = None,
             apex_height: float | None = None) -> GaitLog:
    """``hops`` hops on flat ground with the controller's own foot placement (Raibert's), the wanted horizontal
    velocity before apex k being ``velocities(k)`` ((vx, vy) [m/s]), and at the apexes in ``pushes`` ({k: (Jx, Jy)})
    a horizontal impulse [N s] on the whole robot, hopping to apexes ``apex_height`` high (default APEX_HEIGHT in the
    hopper's lengths). Starts level at an apex moving at ``velocities(0)``."""
    params = params or SpatialRobotParams()
    height = APEX_HEIGHT * units_of(params.slip).length if apex_height is None else apex_height

    def command(k):
        vx, vy = (float(v) for v in velocities(k))
        return SpatialCommand((), apex_height=height, stamp=k, velocity=(vx, vy))

    sd = _flat_diagram(params)
    velocity = command(0).velocity
    return _run(sd, (0.0, 0.0, height, *velocity), sd.controller.raibert_direction(velocity, velocity), command,
                hops, pushes or {})


def execute(apex, height_map: HeightMap, footholds, params: SpatialRobotParams | None = None,
            apex_height: float | None = None, trajectory: bool = False) -> GaitLog:
    """Hop the robot from ``apex`` (x, y, z, vx, vy; body level, facing +x, leg aimed at the first foothold) over
    ``height_map``, touching down on each of ``footholds`` ((x, y, z) of the contact) and stopping at the apex after
    the last, keeping the start's energy on the footholds (as the template does) and hopping ``apex_height`` high
    (default the start's) after them; the log holds the plant's trajectory where ``trajectory``."""
    params = params or SpatialRobotParams()
    apex = tuple(float(v) for v in apex)
    footholds = tuple(tuple(float(v) for v in f) for f in footholds)
    command = SpatialCommand(footholds, apex_height=apex[2] if apex_height is None else float(apex_height),
                             velocity=apex[3:5])
    sd = _map_diagram(height_map, params)
    return _run(sd, apex, leg_toward(apex, footholds[0] if footholds else None, params), lambda k: command,
                len(footholds) + 1, {}, trajectory)


def leg_toward(apex, foothold, params: SpatialRobotParams) -> tuple:
    """The world leg direction at the start ``apex`` (x, y, z, vx, vy) that lands the foot on ``foothold`` (x, y, z
    of the contact; None: straight down)."""
    if foothold is None:
        return 0.0, 0.0, -1.0
    return tuple(aim_direction(apex[:3], (*apex[3:5], 0.0), np.add(foothold, (0.0, 0.0, params.foot_radius)),
                               params.rest_extension, params.slip.gravity)[0])


def _run(sd, apex, leg, commands, hops: int, pushes: dict, trajectory: bool = False) -> GaitLog:
    """Run ``sd`` from ``apex`` (x, y, z, vx, vy) with the leg along the world direction ``leg``, the command
    ``commands(k)`` from apex k on, the impulses ``pushes`` ({k: (Jx, Jy)} [N s]) at their apexes, until ``hops``
    apexes or a failure; the plant's positions logged where ``trajectory``."""
    params = sd.params
    simulator = Simulator(sd.diagram)
    context = simulator.get_mutable_context()
    set_apex_state(sd, context, apex[:3], apex[3:5], leg, LOSS_PRIOR * units_of(params.slip).speed ** 2)
    set_command(sd, context, commands(0))
    monitor = SpatialMonitor(sd, context, trajectory=trajectory)
    simulator.set_monitor(monitor)
    plant_context = sd.plant.GetMyMutableContextFromRoot(context)
    linear = list(sd.layout.linear)
    while monitor.log.failure is None and len(monitor.log.apexes) < hops:
        monitor.at_apex = False
        advance(simulator, context.get_time() + monitor.hop_seconds * 2,
                lambda: f"the spatial robot's hop {len(monitor.log.touchdowns)}", initialize=not monitor.log.apexes)
        if not monitor.at_apex:
            break
        k = len(monitor.log.apexes)
        set_command(sd, context, commands(k))
        if k in pushes:
            x = sd.plant.GetPositionsAndVelocities(plant_context)
            x[linear[:2]] += np.asarray(pushes[k], dtype=float) / params.total_mass
            sd.plant.SetPositionsAndVelocities(plant_context, x)
    return monitor.log


_built: dict = {}


def _flat_diagram(params: SpatialRobotParams):
    """The robot on flat ground, built once per robot (building takes ~0.1 s)."""
    key = ("flat", params)
    if key not in _built:
        cell = 10.0 * units_of(params.slip).length   # 400 m across in the paper's lengths: one box
        _built.clear()
        _built[key] = build_spatial_diagram(HeightMap(np.zeros((40, 40)), cell, (-20 * cell, -20 * cell)), params)
    return _built[key]


def _map_diagram(height_map: HeightMap, params: SpatialRobotParams):
    """The robot on ``height_map``, reused while the map (by identity: its cells are not compared at every call) and
    the robot stay the same."""
    key = (id(height_map), params)
    if key not in _built or _built[key].height_map is not height_map:
        _built.clear()
        _built[key] = build_spatial_diagram(height_map, params)
    return _built[key]


TURN_RATE = math.radians(22.5)   # the wanted heading turns by at most this a hop: a 90 degree turn over four hops
TURN_TOLERANCE = math.radians(5.0)   # a turn is done when the heading is within this of the wanted one ...
SPEED_TOLERANCE = 0.25   # [m/s] ... and the velocity within this of the wanted one (a push is undone), from then on


def settled_after(log: GaitLog, wanted, start: int) -> int | None:
    """Hops from apex ``start`` to the first apex from which every apex's velocity is within SPEED_TOLERANCE (in the
    hopper's speeds) of ``wanted(k)`` and, moving, its heading within TURN_TOLERANCE of it; None if never."""
    tolerance = SPEED_TOLERANCE * log.speed_unit
    settled = None
    for k, apex in enumerate(log.apexes[start:], start):
        vx, vy = apex[4], apex[5]
        wx, wy = wanted(k)
        heading_error = abs(math.remainder(math.atan2(vy, vx) - math.atan2(wy, wx), math.tau)) \
            if math.hypot(wx, wy) > tolerance else 0.0
        good = math.hypot(vx - wx, vy - wy) <= tolerance and heading_error <= TURN_TOLERANCE
        settled = (settled if settled is not None else k) if good else None
    return None if settled is None else settled - start


def turn(speed: float, hops_before: int = 10, hops_after: int = 20, params: SpatialRobotParams | None = None):
    """A 90 degree turn to the left at ``speed``: heading 0 for ``hops_before`` hops, then the wanted heading turning at
    TURN_RATE a hop to 90 degrees from apex ``hops_before`` on. Returns (GaitLog, hops from that apex until the
    velocity is the final one, or None)."""
    def wanted(k):
        heading = min(math.pi / 2, max(0, k - hops_before + 1) * TURN_RATE)
        return speed * math.cos(heading), speed * math.sin(heading)

    log = hop_flat(wanted, hops_before + hops_after, params)
    final = (0.0, speed)
    return log, (settled_after(log, lambda k: final, hops_before) if log.failure is None else None)


def push(speed: float, heading: float, impulse: float, hops_before: int = 10, hops_after: int = 15,
         params: SpatialRobotParams | None = None):
    """Hopping at ``speed`` in ``heading`` [rad], a push of ``impulse`` [N s] to the left of the heading at apex
    ``hops_before``. Returns (GaitLog, hops from the push until the velocity is back, or None)."""
    wanted_velocity = (speed * math.cos(heading), speed * math.sin(heading))
    kick = (-impulse * math.sin(heading), impulse * math.cos(heading))
    log = hop_flat(lambda k: wanted_velocity, hops_before + hops_after, params, pushes={hops_before: kick})
    return log, (settled_after(log, lambda k: wanted_velocity, hops_before) if log.failure is None else None)
