"""What a multibody run did, hop by hop, and how it failed: a Simulator monitor that reads the plant's state and
the controller's phase after every step.

Failures carry the SLIP's names (``FailureMode``) with what happened on the robot (``RobotFailure.what``):
FOOT_COLLISION — the foot in a ditch (below its rim) or pressed into a step's vertical face; TRIP — the foot
meets the ground while swinging forward after liftoff; SLIP — the foot slides ``SLIP_DISTANCE`` in stance;
BOTTOM_OUT — the leg reaches its bottom-out stop; STALL — no apex with forward speed toward a foothold ahead, or
a phase of a hop longer than ``drakeslip.units.HOP_SECONDS`` in its template's time units (the robot's legs stand
still); BODY_COLLISION — a fall: the body pitches past ``PITCH_LIMIT`` or a corner of
the body box reaches the terrain.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from pydrake.systems.framework import EventStatus

from drakeslip.multibody.controller import Heights, Phase, Sensed
from drakeslip.multibody.robot import model_geometry
from drakeslip.state import ApexState, FailureMode
from drakeslip.terrain import Terrain
from drakeslip.units import units_of

# The thresholds, the paper's hopper's; a hopper's own are these lengths and times in its units (``HopMonitor``),
# as are the millimetres and centimetres of the foot's checks
PITCH_LIMIT = 0.8      # [rad] a body pitched further than this has fallen
SLIP_DISTANCE = 0.02   # [m] foot travel in one stance, beyond the ball's rolling, that counts as slipping
TRIP_GRACE = 0.04      # [s] after liftoff the foot is still leaving the ground


@dataclass(frozen=True)
class RobotFailure:
    """A named failure: ``mode`` (the SLIP's name), ``what`` (on the robot), ``time`` [s], ``x`` of the body and
    ``hop`` (touchdowns before it)."""

    mode: FailureMode
    what: str
    time: float
    x: float
    hop: int
    state: tuple


@dataclass
class HopLog:
    """Touchdowns (foot x, absolute leg angle, time, and in ``aimed`` the stamp of the command the controller
    followed and the index of its foothold the touchdown aimed at: an index past the command's footholds is a
    touchdown by Raibert's placement), liftoff times, apexes, the largest |pitch| (overall, and over each hop up to
    its apex in ``hop_pitch``), the failure (None if none), and with ``trajectory`` the times and plant positions of
    every step."""

    footholds: list = field(default_factory=list)
    leg_angles: list = field(default_factory=list)
    touchdown_times: list = field(default_factory=list)
    aimed: list = field(default_factory=list)
    liftoff_times: list = field(default_factory=list)
    apexes: list = field(default_factory=list)
    max_pitch: float = 0.0
    hop_pitch: list = field(default_factory=list)
    failure: RobotFailure | None = None
    times: list = field(default_factory=list)
    positions: list = field(default_factory=list)


class HopMonitor:
    """A ``Simulator.set_monitor`` callback over a ``HopperDiagram``: logs hops into ``log`` and ends the run at a
    failure or after ``max_apexes`` apexes (None: never). ``command_footholds``, set by the caller, are the
    footholds the robot is commanded to: a STALL at an apex needs one of them ahead."""

    command_footholds: tuple = ()

    def __init__(self, hd, terrain: Terrain, root_context, max_apexes: int | None, trajectory: bool = False):
        self.hd, self.terrain, self.max_apexes, self.trajectory = hd, terrain, max_apexes, trajectory
        self.plant_context = hd.plant.GetMyContextFromRoot(root_context)
        self.controller_context = hd.controller.GetMyContextFromRoot(root_context)
        self.log = HopLog()
        self.height = Heights(terrain)
        self.phase = None
        self.phase_start = 0.0
        self.hop_pitch = 0.0
        p = hd.params
        self.radius, self.bottom = p.foot_radius, p.bottom_extension
        self.body_half = model_geometry(p).body_half   # half length and half height of the body box
        units = units_of(p.slip)
        self.hop_seconds = units.hop_seconds   # a phase longer than this is a STALL
        self.length, self.trip_grace, self.slip_distance = units.length, TRIP_GRACE * units.time, \
            SLIP_DISTANCE * units.length
        self.sensed_index = list(hd.layout.q) + list(hd.layout.v)

    def __call__(self, root_context):
        t = root_context.get_time()
        full = self.hd.plant.get_state_output_port().Eval(self.plant_context)
        m = Sensed(full[self.sensed_index])
        c = self.hd.controller.control_state_of(self.controller_context)
        log = self.log
        if self.trajectory:
            log.times.append(t)
            log.positions.append(full[:self.hd.plant.num_positions()].copy())
        log.max_pitch = max(log.max_pitch, abs(m.pitch))
        self.hop_pitch = max(self.hop_pitch, abs(m.pitch))
        phase = Phase(int(c.phase))
        if phase != self.phase:
            if phase == Phase.STANCE:
                log.footholds.append(float(c.touchdown_x))
                log.leg_angles.append(float(c.touchdown_angle))
                log.touchdown_times.append(t)
                log.aimed.append((int(c.stamp), int(c.step) - 1))   # the touchdown counted itself in its step
            elif self.phase == Phase.STANCE:
                log.liftoff_times.append(t)
            elif phase == Phase.DESCENT and self.phase == Phase.ASCENT:
                log.apexes.append(ApexState(float(m.x), float(m.z), float(m.xd)))
                log.hop_pitch.append(self.hop_pitch)
                self.hop_pitch = 0.0
            self.phase, self.phase_start = phase, t
        failure = self._body_failure(m) or self._foot_failure(t, m, phase, c) or self._stall(t, m, phase)
        if failure is not None:
            log.failure = RobotFailure(failure[0], failure[1], t, float(m.x), len(log.footholds),
                                       (float(m.x), float(m.z), float(m.xd), float(m.zd)))
            return EventStatus.ReachedTermination(self.hd.diagram, f"{failure[0].name}: {failure[1]}")
        if self.max_apexes is not None and len(log.apexes) >= self.max_apexes:
            return EventStatus.ReachedTermination(self.hd.diagram, "commands done")
        return EventStatus.Succeeded()

    def _body_failure(self, m: Sensed):
        """A fall: the body pitched past PITCH_LIMIT, or a corner of its box below the ground."""
        if abs(m.pitch) > PITCH_LIMIT:
            return FailureMode.BODY_COLLISION, f"fall: the body pitched to {m.pitch:+.2f} rad"
        cp, sp = math.cos(m.pitch), math.sin(m.pitch)
        half_length, half_height = self.body_half
        for u, w in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
            # the body box's corners: body x turns toward z with positive pitch
            cx = m.x + u * half_length * cp - w * half_height * sp
            cz = m.z + u * half_length * sp + w * half_height * cp
            if cz < self.height(cx):
                return FailureMode.BODY_COLLISION, f"fall: the body touched the ground at x={cx:.2f}"
        return None

    def _foot_failure(self, t, m: Sensed, phase: Phase, c):
        """The leg at its bottom-out stop, the foot in a step's face or a ditch, a trip or a slip."""
        terrain, height = self.terrain, self.height
        angle = m.pitch + m.hip
        fx, fz = m.x + m.leg * math.sin(angle), m.z - m.leg * math.cos(angle) - self.radius
        mm = 1e-3 * self.length
        if m.leg <= self.bottom + mm:
            return FailureMode.BOTTOM_OUT, "the leg reached its bottom-out stop"
        reach = self.radius - 2 * mm   # the ball's side, less the contact's compliance
        around = max(height(fx - reach), height(fx + reach))
        in_ditch = height(fx) <= terrain.ditch_height
        if fz < around - 10 * mm and not in_ditch:
            return FailureMode.FOOT_COLLISION, f"the foot pressed into a step's face at x={fx:.2f}"
        if in_ditch:
            rim = _rim_below(terrain, fx)
            if fz < rim - 20 * mm:
                return FailureMode.FOOT_COLLISION, f"the foot went into a ditch at x={fx:.2f}"
        if phase == Phase.ASCENT and t - self.phase_start > self.trip_grace and fz < height(fx) + mm:
            return FailureMode.TRIP, f"the swinging foot caught the ground at x={fx:.2f}"
        # the ball rolls as the leg turns over it: its centre moves r (angle at touchdown - angle) with no slip
        slide = fx - c.touchdown_x - self.radius * (c.touchdown_angle - angle)
        if phase == Phase.STANCE and abs(slide) > self.slip_distance:
            return FailureMode.SLIP, f"the foot slid {slide:+.3f} m in stance"
        return None

    def _stall(self, t, m: Sensed, phase: Phase):
        """A phase longer than ``hop_seconds``, or an apex with no forward speed toward a foothold ahead."""
        if t - self.phase_start > self.hop_seconds:
            return FailureMode.STALL, "no hop completed"
        footholds = self.command_footholds
        if phase == Phase.DESCENT and self.phase_start == t and m.xd <= 0.0 and footholds \
                and footholds[-1] > m.x + 0.05 * self.length:
            return FailureMode.STALL, f"no forward speed at the apex (xdot={m.xd:+.2f} m/s)"
        return None


def _rim_below(terrain: Terrain, x: float) -> float:
    """The lower of the solid heights on both sides of the ditch under ``x``."""
    i = int(terrain.index(x))
    h = terrain.heights
    solid = np.flatnonzero(h > terrain.ditch_height)
    before, after = solid[solid < i], solid[solid > i]
    rims = [float(h[before[-1]])] if before.size else []
    rims += [float(h[after[0]])] if after.size else []
    return min(rims) if rims else terrain.ditch_height
