"""The hopper's low-level controller, a Drake ``LeafSystem`` running at the robot's control rate.

It reads what the robot senses — the body state estimate (x, z, pitch and rates) and the joint encoders (hip
angle, leg extension and rates) on ``state`` — and the footstep command on ``command`` (a ``FootholdCommand``:
the footholds from the next touchdown on, the height map they were chosen on, and the energy per kg of body the
plan's apexes have). Contact is inferred from the leg's compression, never from the simulator. Its output
``actuation`` is (hip torque, leg force), inside the motor's torque-speed envelope and the leg actuator's force
limit, applied one control period after the measurement it comes from.

Phases (``Phase``, the discrete state's ``phase``; the constants are ``drakeslip.multibody.gains``', in the hopper's
units): ASCENT, from liftoff to apex: the leg retracts ``RETRACT`` and,
until the foot is ``CLEARANCE`` above the ground, swings back under the hip's advance so that the foot rises where it
stood (dragged forward, a foot near a step's face catches it and kicks the leg and body round); then it swings to
the neutral angle (half the stance's travel ahead, Raibert's), where it waits for the footholds the planner chooses
at the apex; DESCENT, from apex (vertical velocity reaching zero) to touchdown (the leg compressing): the leg
extends to its stop and the hip aims it at the angle that lands the foot on the commanded foothold, recomputed each
period from the body's ballistic path, and swings it back as it lands (``LANDING_SWING_SHARE``) so that the foot,
which has mass, meets the ground slower than the body moves instead of sliding before the leg's force holds it
(ground-speed matching); STANCE, to liftoff (the leg back at its stop): the hip torque keeps the body level
(within the friction cone's share of the leg force) and the leg actuator pushes during extension until the body
has the energy the next planned apex needs plus what the unsprung foot's liftoff will take. The energy each hop
still falls short of at its apex (damping, the model's errors) is learned as a bias added to the next targets.
"""
from __future__ import annotations

import enum
import functools
import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from pydrake.common.containers import namedview
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, LeafSystem

from drakeslip.multibody.gains import BIAS_GAIN, FRICTION_SHARE, LANDING_SWING_SHARE, control_constants
from drakeslip.multibody.robot import RobotParams, StateLayout, model_geometry
from drakeslip.terrain import Terrain


class Phase(enum.IntEnum):
    """The controller's phase of a hop (see the module doc)."""

    ASCENT = 0
    DESCENT = 1
    STANCE = 2


# The discrete state: the phase (a Phase); touchdowns since the command arrived; the command's stamp; apexes
# reached; the learned energy bias [J/kg]; this hop's energy target [J/kg] (NaN: none yet); the hip torque and leg
# force sent; the time the phase began; the foot's x and the absolute leg angle at touchdown.
ControlState = namedview("ControlState", ["phase", "step", "stamp", "apexes", "bias", "target", "torque", "force",
                                          "phase_start", "touchdown_x", "touchdown_angle"])
# What the robot senses: the body's x, z and pitch, the hip angle and the leg extension, and their rates.
Sensed = namedview("Sensed", ["x", "z", "pitch", "hip", "leg", "xd", "zd", "pitchd", "hipd", "legd"])



class Heights:
    """A terrain's height at a scalar x, in plain Python (``Terrain.height_at`` is made for arrays)."""

    def __init__(self, terrain: Terrain):
        self.terrain, self.x0, self.cell = terrain, terrain.x0, terrain.cell
        self.values = terrain.heights.tolist()
        self.last = len(self.values) - 1

    def __call__(self, x: float) -> float:
        return self.values[min(max(int(math.floor((x - self.x0) / self.cell)), 0), self.last)]


@dataclass(frozen=True)
class FootholdCommand:
    """Footholds (x, from the next touchdown on) on the height map ``terrain``; ``energy`` [J/kg of body] the
    planned apexes' g z + xdot^2 / 2 (None: keep the energy of the last apex); ``stamp`` tells one command from
    the next (the controller counts touchdowns from a new stamp on). Past its last foothold (or with none) the
    controller places the foot by Raibert's rule for the forward ``speed`` [m/s] (0: hopping in place).
    ``apex_errors`` ((x, z, xdot) per step) perturb the body state the controller aims from (state estimation:
    the estimate at the apex is that far off, and its speed error carries into its position through the
    descent) and ``angle_errors`` (rad per step) the leg angle it reaches (actuation), as the SLIP's rollouts
    do."""

    footholds: tuple
    terrain: Terrain
    energy: float | None
    stamp: int = 0
    speed: float = 0.0
    apex_errors: tuple = ()
    angle_errors: tuple = ()

    def __deepcopy__(self, memo):
        return self   # immutable (frozen, tuples, a read-only terrain): Drake's state copies may share it

    @functools.cached_property
    def heights(self) -> Heights:
        """The height of ``terrain`` at a scalar x, looked up at every control period of a descent."""
        return Heights(self.terrain)


def apex_energy(z: float, xdot: float, gravity: float) -> float:
    """Energy per kg of an apex at height ``z`` (world) moving at ``xdot``."""
    return gravity * z + 0.5 * xdot * xdot


class HeldLeg(NamedTuple):
    """A leg held at a fixed angle in flight: the foot ball's centre ``reach`` [m] from the hip, the ball's
    ``foot_radius`` [m], and the ``gravity`` [m/s^2] the body falls under."""

    reach: float
    foot_radius: float
    gravity: float


def time_to_ground(z, zdot, angle, ground, leg: HeldLeg) -> float:
    """Seconds until the foot ball of ``leg`` held at ``angle`` reaches ``ground`` on the body's ballistic path
    from height ``z`` rising at ``zdot``."""
    reach, foot_radius, gravity = leg
    drop = z - reach * math.cos(angle) - foot_radius - ground
    disc = zdot * zdot + 2.0 * gravity * drop
    return (zdot + math.sqrt(disc)) / gravity if disc > 0 else max(zdot / gravity, 0.0)


def touchdown_angle(x, z, xdot, zdot, foothold_x, ground, leg: HeldLeg) -> float:
    """The absolute leg angle (SLIP convention) that, held from the body state (x, z, xdot, zdot) on its
    ballistic path, lands the foot ball's centre (``leg.reach`` from the hip) above ``foothold_x`` when its bottom
    reaches ``ground``; clipped to [-1, 1] rad. Bisection: the landing x grows with the angle."""
    lo, hi = -1.0, 1.0
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        t = time_to_ground(z, zdot, mid, ground, leg)
        if x + xdot * t + leg.reach * math.sin(mid) < foothold_x:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def motor_torque(torque: float, speed: float, params: RobotParams) -> float:
    """``torque`` inside the hip motor's envelope: the limit at stall, falling linearly to zero at the speed
    limit when driving (torque and speed of one sign), the full limit when braking."""
    limit = params.hip_torque_limit
    if torque * speed > 0:
        limit *= max(0.0, 1.0 - abs(speed) / params.hip_speed_limit)
    return max(-limit, min(limit, torque))


def neutral_angle(xdot: float, leg_length: float, stance: float, offset: float = 0.0) -> float:
    """The leg angle that puts the foot at the neutral point, half the ``stance`` [s] travel ahead of the hip at
    forward speed ``xdot``, plus ``offset`` [m]: where the leg waits through the apex in flight."""
    return math.asin(max(-0.8, min(0.8, (0.5 * xdot * stance + offset) / leg_length)))


def swing_inertia(params, reach: float, leg_com: float, leg_inertia: float) -> float:
    """The leg's inertia about the hip in flight [kg m^2], the body free: the foot ``reach`` and the upper leg's
    centre of mass ``leg_com`` below the hip (each mass reduced by the rest of the robot's, as a swing against a
    free body sees it) plus the upper leg's own ``leg_inertia``; ``params`` a robot's (``total_mass``,
    ``foot_mass``, ``leg_mass``). Over the body's inertia, the share of a swing the body turns back."""
    m = params.total_mass
    return (params.foot_mass * (m - params.foot_mass) / m * reach ** 2
            + params.leg_mass * (m - params.leg_mass) / m * leg_com ** 2 + leg_inertia)


class HopperController(LeafSystem):
    """The robot's controller at its control rate (``RobotParams.time_step``); see the module doc.

    Input ports
      state: the plant's state vector, read through ``layout`` (``Sensed``).
      command: abstract ``FootholdCommand``.
    Output port
      actuation: the plant's actuation vector (hip torque, leg force at ``layout.actuation``).
    State
      discrete (``ControlState``): phase (``Phase``), step, stamp, apexes, bias, target, torque, force,
      phase_start, touchdown_x, touchdown_angle.
    Parameters
      ``params`` (the robot the controller knows: a noise profile's model mismatch runs another plant),
      ``layout`` (the robot in the plant), ``inject_energy`` (False: the leg actuator only retracts and extends
      the leg in flight, so nothing returns the energy each hop loses); the upper leg's mass distribution, the
      gains, thresholds and stance time come from them (``model_geometry``,
      ``drakeslip.multibody.gains.control_constants``). Everything that changes lives in the Context.
    """

    def __init__(self, params: RobotParams, layout: StateLayout, inject_energy: bool = True):
        super().__init__()
        self.params, self.layout, self.inject_energy = params, layout, bool(inject_energy)
        self._sensed = list(layout.q) + list(layout.v)
        geometry = model_geometry(params)
        self.leg_com, self.leg_inertia = geometry.leg_com, geometry.leg_inertia
        self.scaled = control_constants(params.slip)   # the gains, thresholds and stance time in this hopper's units
        self.pitch_inertia = params.body_pitch_inertia
        self.foot_share = params.foot_mass / params.slip.mass
        # the leg's inertia about the hip in flight (leg retracted; the foot's mass reduced by the body's)
        leg_inertia = swing_inertia(params, params.rest_extension - self.scaled.retract, self.leg_com, self.leg_inertia)
        self.swing_ratio = leg_inertia / params.body_pitch_inertia
        self.state_port = self.DeclareVectorInputPort("state", max(layout.v) + 1)
        empty = FootholdCommand((), Terrain.flat(), None, -1)
        self.command_port = self.DeclareAbstractInputPort("command", AbstractValue.Make(empty))
        self.control_state = self.DeclareDiscreteState(len(ControlState.get_fields()))
        self.DeclarePeriodicDiscreteUpdateEvent(params.time_step, 0.0, self._update)
        self.DeclareVectorOutputPort("actuation", layout.n_actuators, self._output,
                                     prerequisites_of_calc={self.discrete_state_ticket(self.control_state)})

    def initial_state(self, phase: Phase = Phase.DESCENT, energy_bias: float = 0.0) -> np.ndarray:
        """A discrete state vector to start from (``phase``, a known ``energy_bias``)."""
        s = ControlState.Zero()
        s.phase, s.stamp, s.bias, s.target = phase, -1.0, energy_bias, math.nan
        return np.asarray(s)

    def control_state_of(self, context) -> ControlState:
        """The controller's state in its ``context`` (a read-only view)."""
        return ControlState(context.get_discrete_state(self.control_state).get_value())

    def _output(self, context, output: BasicVector):
        s = self.control_state_of(context)
        u = np.zeros(self.layout.n_actuators)
        u[self.layout.actuation[0]], u[self.layout.actuation[1]] = s.torque, s.force
        output.SetFromVector(u)

    def raibert_angle(self, xdot: float, speed: float) -> float:
        """The leg angle that puts the foot at the neutral point (half the stance's travel ahead of the hip)
        plus ``SPEED_GAIN`` times the speed error: Raibert's speed control for hopping without footholds."""
        return neutral_angle(xdot, self.params.slip.leg_length, self.scaled.stance_time,
                             self.scaled.speed_gain * (xdot - speed))

    def _update(self, context, discrete_state):
        s = ControlState(discrete_state.get_mutable_vector(self.control_state).get_mutable_value())
        m = Sensed(self.state_port.Eval(context)[self._sensed])
        command = self.command_port.Eval(context)
        t = context.get_time()
        if command.stamp != s.stamp:
            s.stamp, s.step = command.stamp, 0.0
            if command.energy is not None and s.phase == Phase.DESCENT:
                s.target = command.energy   # the command of the planner's apex (the apex this descent began at)
        phase = self._next_phase(s, m, command, t)
        if phase != s.phase:
            s.phase, s.phase_start = phase, t
        if math.isnan(s.target):
            s.target = command.energy if command.energy is not None else apex_energy(m.z, m.xd,
                                                                                      self.params.slip.gravity)
        if phase == Phase.STANCE:
            torque, force = self._stance_control(s, m)
        else:
            torque, force = self._flight_control(s, m, command, t, phase)
        s.torque = motor_torque(torque, m.hipd, self.params)
        s.force = force

    def _next_phase(self, s: ControlState, m: Sensed, command: FootholdCommand, t: float) -> Phase:
        """The phase after this period's measurement: an apex (learning the energy it missed and taking the next
        target), a touchdown (counting it and recording where) or a liftoff ends the phase."""
        rest, g = self.params.rest_extension, self.params.slip.gravity
        phase = Phase(int(s.phase))
        if phase == Phase.ASCENT and m.zd <= 0.0:
            s.apexes += 1.0
            energy = apex_energy(m.z, m.xd, g)
            if not math.isnan(s.target):
                s.bias += BIAS_GAIN * (s.target - energy)
            s.target = command.energy if command.energy is not None else energy
            return Phase.DESCENT
        if phase == Phase.DESCENT and rest - m.leg > self.scaled.touchdown_compression \
                and m.legd < self.scaled.touchdown_rate:
            s.step += 1.0
            s.touchdown_x = m.x + m.leg * math.sin(m.pitch + m.hip)
            s.touchdown_angle = m.pitch + m.hip
            return Phase.STANCE
        if phase == Phase.STANCE and t - s.phase_start > self.scaled.min_stance \
                and m.leg >= rest - self.scaled.liftoff_margin:
            return Phase.ASCENT
        return phase

    def _stance_control(self, s: ControlState, m: Sensed) -> tuple:
        """(hip torque, leg force) in stance: the body's pitch and the robot's angular momentum held, the leg
        pushing during extension until the body has this hop's energy target."""
        p = self.params
        slip, rest, g = p.slip, p.rest_extension, p.slip.gravity
        z, xd, zd, leg, legd = m.z, m.xd, m.zd, m.leg, m.legd
        angle, angle_rate = m.pitch + m.hip, m.pitchd + m.hipd
        kp, kd = self.scaled.stance_gains
        # lean against the pitch the next flight's leg swing will cause (about symmetric: -angle to +angle)
        lean = self.swing_ratio * s.touchdown_angle
        momentum = self._angular_momentum(m.pitchd, leg, legd, angle, angle_rate)
        # the leg pushes the body toward the lean and the robot's angular momentum toward zero, so that
        # the leg's swing in flight (which cannot change it) ends with the body near level
        torque = kp * (m.pitch - lean) + kd * momentum / self.pitch_inertia
        leg_force = slip.stiffness * max(rest - leg, 0.0)
        reach = leg + p.foot_radius
        torque_cap = FRICTION_SHARE * slip.friction * leg_force * reach
        torque = max(-torque_cap, min(torque_cap, torque))
        force = 0.0
        if self.inject_energy and legd > 0.0:
            energy = g * z + 0.5 * (xd * xd + zd * zd) + 0.5 * slip.stiffness * (rest - leg) ** 2 / slip.mass
            # the foot, at rest on the ground, is jerked to the body's speed at liftoff: a plastic impact
            liftoff_loss = 0.5 * self.foot_share * (xd * xd + zd * zd)
            need = s.target + liftoff_loss + s.bias - energy
            force = slip.mass * need / max(rest - leg, self.scaled.least_stroke)
            force = max(-0.5 * p.leg_force_limit, min(p.leg_force_limit, force))
        return torque, force

    def _flight_control(self, s: ControlState, m: Sensed, command: FootholdCommand, t: float, phase: Phase):
        """(hip torque, leg force) in flight: the hip aims the leg (``_flight_target``) and the leg retracts in
        ascent and extends to its stop in descent."""
        p = self.params
        rest, leg, legd = p.rest_extension, m.leg, m.legd
        angle, angle_rate = m.pitch + m.hip, m.pitchd + m.hipd
        target, rate = self._flight_target(s, m, command, t, phase)
        kp, kd = self.scaled.flight_gains
        if phase == Phase.ASCENT and self._clearance(m.x, m.z, leg, angle, target, command) < self.scaled.clearance:
            # the foot is leaving the ground: the leg retracts and swings back at the rate that keeps the foot
            # over the ground it left
            kp, kd = 0.0, self.scaled.lift_damping
            rate = -(m.xd + legd * math.sin(angle)) / (leg * math.cos(angle))
        torque = kp * (target - angle) + kd * (rate - angle_rate)
        goal = rest - self.scaled.retract if phase == Phase.ASCENT else rest + self.scaled.least_stroke
        kp, kd = self.scaled.leg_gains
        force = kp * (goal - leg) - kd * legd - p.slip.stiffness * (rest - leg)
        force = max(-p.leg_force_limit, min(p.leg_force_limit, force))
        return torque, force

    def _flight_target(self, s: ControlState, m: Sensed, command: FootholdCommand, t: float, phase: Phase):
        """(absolute leg angle, its rate the hip's damping acts about) in flight: the neutral angle in ascent, the
        angle landing the foot on the next foothold in descent, Raibert's placement past the command's last."""
        p = self.params
        step = int(s.step)
        if phase == Phase.ASCENT and step < len(command.footholds):
            # the planner chooses the next foothold at the apex, from the apex reached: a leg swung before
            # then toward the last plan's next foothold swings back when the new plan moves it, and each
            # swing turns the body (swing_ratio); the hops after such swings stray from the template's
            return self.raibert_angle(m.xd, m.xd), 0.0
        if step >= len(command.footholds):
            return self.raibert_angle(m.xd, command.speed), 0.0
        foothold = command.footholds[step]
        ground = command.heights(foothold)
        ex, ez, exd = command.apex_errors[step] if step < len(command.apex_errors) else (0.0, 0.0, 0.0)
        # (this branch is the descent, begun at the apex) the estimate's speed error at the apex carries
        # into its position as the body flies on
        ex += exd * (t - s.phase_start)
        leg = HeldLeg(p.slip.leg_length - p.foot_radius, p.foot_radius, p.slip.gravity)
        target = touchdown_angle(m.x + ex, m.z + ez, m.xd + exd, m.zd, foothold, ground, leg)
        if step < len(command.angle_errors):
            target += command.angle_errors[step]
        # the hip leads the leg by the swing back still to come and damps it about the swing's rate, so
        # that the leg is already swinging back when the foot lands on the foothold
        rate = -LANDING_SWING_SHARE * (m.xd + exd) / (leg.reach * math.cos(target))
        target -= rate * min(time_to_ground(m.z + ez, m.zd, target, ground, leg), self.scaled.landing_swing_time)
        return target, rate

    def _angular_momentum(self, pitchd, leg, legd, angle, angle_rate) -> float:
        """The robot's angular momentum about its centre of mass [N m s] (positive turning x toward z)."""
        p, com = self.params, self.leg_com
        sin, cos = math.sin(angle), math.cos(angle)
        masses = (p.slip.mass, p.leg_mass, p.foot_mass)
        points = ((0.0, 0.0), (com * sin, -com * cos), (leg * sin, -leg * cos))
        rates = ((0.0, 0.0), (com * cos * angle_rate, com * sin * angle_rate),
                 (legd * sin + leg * cos * angle_rate, -legd * cos + leg * sin * angle_rate))
        total = sum(masses)
        cx = sum(m * r[0] for m, r in zip(masses, points)) / total
        cz = sum(m * r[1] for m, r in zip(masses, points)) / total
        vx = sum(m * v[0] for m, v in zip(masses, rates)) / total
        vz = sum(m * v[1] for m, v in zip(masses, rates)) / total
        spin = self.pitch_inertia * pitchd + self.leg_inertia * angle_rate
        return spin + sum(m * ((r[0] - cx) * (v[1] - vz) - (r[1] - cz) * (v[0] - vx))
                          for m, r, v in zip(masses, points, rates))

    def _clearance(self, x, z, leg, angle, target, command: FootholdCommand) -> float:
        """The foot's height above the highest ground between it and where the swing to ``target`` takes it."""
        terrain = command.terrain
        reach = leg + self.params.foot_radius
        foot_x = x + leg * math.sin(angle)
        lo, hi = sorted((foot_x, x + reach * math.sin(target)))
        cells = terrain.heights[terrain.index(lo):terrain.index(hi) + 1]
        ground = float(cells.max()) if cells.size else command.heights(foot_x)
        return z - leg * math.cos(angle) - self.params.foot_radius - ground
