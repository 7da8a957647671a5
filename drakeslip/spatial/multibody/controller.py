"""The spatial hopper's low-level controller, a Drake ``LeafSystem`` at the robot's control rate: Raibert's three
loops in three dimensions (hopping height, foot placement, body attitude), for any hopper.

It reads what the robot senses — the body's pose and twist (an estimate) and the joint encoders (hip pitch and roll,
leg extension, their rates) — on ``state``, and the footstep command on ``command`` (a ``SpatialCommand``). Contact
is inferred from the leg's compression, never from the simulator. Its output ``actuation`` is (hip pitch torque,
hip roll torque, leg force), each hip axis inside its motor's torque-speed envelope.

Phases (``Phase``, as the planar robot's): ASCENT, liftoff to apex: the leg retracts and, until the foot is
``CLEARANCE`` above the highest ground between it and where its swing takes it (on the command's height map), swings
back under the hip's advance so that the foot rises where it stood; then the leg swings to the neutral point (half the
stance's travel ahead of the hip along the velocity). DESCENT, apex to touchdown: the leg extends to its stop and the
hip aims it, in the world frame, at the commanded foothold — the leg direction whose foot, carried on the body's
ballistic path, lands on it, recomputed every period — or, past the command's footholds, at Raibert's point for the
commanded horizontal velocity (the neutral point plus ``SPEED_GAIN`` times the velocity error, in both directions). The
wanted world direction becomes hip angles through the body's measured attitude, so a turned or tilted body still places
the foot where it is asked. STANCE: the hip torques hold the body's roll and pitch at a lean against the next flight's
leg swing and drive the whole robot's angular momentum about its centre of mass toward zero, so that the flight, which
cannot change it, ends level; they are capped by the friction cone. The leg actuator pushes during extension until the
body has the energy of its next apex: on footholds, the total energy the command says (by default the last apex's: the
template's hops keep it); past them, the vertical energy (height, vertical speed, spring) of the commanded apex height,
Raibert's hopping height, left apart from the horizontal speed that placement changes (a push or a turn brakes through
the leg, and a total-energy target would take the braking out of the next hop's height, leaving no flight to place the
foot in), and at least the vertical energy of an apex ``APEX_CLEARANCE`` above a standing leg (room to lift and swing
the foot, which the template's massless leg does not need). The energy each apex misses is learned as a bias. Yaw: the
foot is a point, which holds no torque, and the hip's two axes turn the body about two axes only, both spent on roll and
pitch; the body's yaw is left free (it drifts where both hip axes work, at headings between the body's axes) and
placement, in the world frame, does not need it.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from pydrake.common.containers import namedview
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, LeafSystem

from drakeslip.multibody.controller import Phase, motor_torque, swing_inertia
from drakeslip.multibody.gains import BIAS_GAIN, FRICTION_SHARE, LANDING_SWING_SHARE, SPEED_GAIN, control_constants
from drakeslip.spatial.heightmap import HeightMap, ScalarHeights
from drakeslip.spatial.multibody.aiming import (aim_direction, cross, fall_time, hip_angles, offset_direction,
                                                roll_pitch_yaw, rotation)
from drakeslip.spatial.multibody.robot import SpatialLayout, SpatialRobotParams, leg_direction, spatial_geometry
from drakeslip.units import units_of

# The discrete state: the phase (a Phase); touchdowns since the command arrived; the command's stamp; apexes reached;
# the learned energy bias [J/kg]; this hop's energy target [J/kg] (NaN: none yet) and whether it is the total energy
# (1) or the vertical (0), and whether the apex floor set this stance's push instead (1); the hip torques and leg
# force sent; the time the phase began; the height of the ground the
# foot touched down on; the body lean held in stance (roll, pitch, Drake's roll-pitch-yaw angles) [rad]; the learned
# foot offset [m] that removes the speed error Raibert's placement leaves.
ControlState = namedview("ControlState", ["phase", "step", "stamp", "apexes", "bias", "target", "total", "floored",
                                          "torque_pitch", "torque_roll", "force", "phase_start", "touchdown_z",
                                          "lean_roll", "lean_pitch", "offset_x", "offset_y"])


class Sensed(NamedTuple):
    """What the controller reads at a period: the body's ``position`` and ``velocity`` (its origin, the hip; world),
    its angular velocity ``omega`` (world) and ``rotation`` (body to world), the ``hip`` angles (pitch, roll) and
    their ``hip_rates``, the ``leg`` extension and its ``leg_rate``."""

    position: np.ndarray
    velocity: np.ndarray
    omega: np.ndarray
    rotation: np.ndarray
    hip: np.ndarray
    hip_rates: np.ndarray
    leg: float
    leg_rate: float


# [m] the stance gives the body at least the vertical energy of an apex this far above a standing leg's length over
# the foothold: room for the leg's retraction (RETRACT) and the foot's clearance (CLEARANCE) as it swings forward,
# and a centimetre (the planar robot raises such hops by its pump, drakeslip.multibody.pump)
APEX_CLEARANCE = 0.08
# share of SPEED_GAIN times an apex's speed error learned into the foot's offset: Raibert's placement is a
# proportional law whose neutral point is an estimate, so it settles off the wanted speed (2.73 m/s for 3) without it
OFFSET_GAIN = 0.5
OFFSET_ERROR = 0.2   # [m/s] ... of a speed error clipped to this: a push or a turn is the proportional law's to undo
# Raibert's placement keeps the leg at touchdown within this share of the friction cone (tan of its angle from the
# vertical at most this times the friction): a foot put farther out to turn or to stop a push slides as it lands
CONE_SHARE = 0.8


@dataclass(frozen=True)
class SpatialCommand:
    """Footholds ((x, y, z) of the ground contact, from the next touchdown on); ``energy`` [J/kg of body], the total
    energy g z + |v|^2 / 2 of the apexes between them (None: the last apex's, as the template keeps it); past them,
    ``apex_height`` [m, world z], the apexes' height (None: the last apex's), and the foot at Raibert's point for the
    horizontal ``velocity`` (vx, vy) [m/s] ((0, 0): hopping in place); ``stamp`` tells one command from the next (the
    controller counts touchdowns from a new stamp on); ``height_map``, the ground as the robot senses it, which the
    foot lifted after liftoff clears before it swings forward (None: flat at the height the foot left)."""

    footholds: tuple = ()
    energy: float | None = None
    apex_height: float | None = None
    stamp: int = 0
    velocity: tuple = (0.0, 0.0)
    height_map: HeightMap | None = None

    @functools.cached_property
    def heights(self) -> ScalarHeights | None:
        """``height_map`` read at scalar points (None without one)."""
        return None if self.height_map is None else ScalarHeights(self.height_map)

    def __deepcopy__(self, memo):
        return self   # immutable: Drake's state copies may share it


class SpatialHopperController(LeafSystem):
    """The spatial robot's controller at its control rate (``SpatialRobotParams.time_step``); see the module doc.

    Input ports
      state: the plant's state vector, read through ``layout``.
      command: abstract ``SpatialCommand``.
    Output port
      actuation: the plant's actuation vector (hip pitch, hip roll, leg at ``layout.actuation``).
    State
      discrete (``ControlState``): phase (``Phase``), step, stamp, apexes, bias, target, total, floored, torque_pitch,
      torque_roll, force, phase_start, touchdown_z, lean_roll, lean_pitch, offset_x, offset_y.
    Parameters
      ``params`` (the robot the controller knows), ``layout`` (the robot in the plant). Gains, thresholds and the
      stance time are the planar robot's (``drakeslip.multibody.controller``) in the hopper's units.
    """

    def __init__(self, params: SpatialRobotParams, layout: SpatialLayout):
        super().__init__()
        self.params, self.layout = params, layout
        u = units_of(params.slip)
        self.scaled = control_constants(params.slip)   # the planar robot's gains and thresholds in these units
        self.apex_floor = params.slip.leg_length + APEX_CLEARANCE * u.length
        self.cone_reach = math.sin(math.atan(CONE_SHARE * params.slip.friction))
        geometry = spatial_geometry(params)
        self.leg_com, self.leg_inertia = geometry.leg_com, geometry.leg_inertia
        self.inertia = np.array([params.body_roll_inertia, params.body_pitch_inertia, params.body_yaw_inertia])
        self.foot_share = params.foot_mass / params.slip.mass
        swing = swing_inertia(params, params.rest_extension - self.scaled.retract, self.leg_com,
                              self.leg_inertia[0])
        self.swing_ratio = (swing / params.body_roll_inertia, swing / params.body_pitch_inertia)
        self.state_port = self.DeclareVectorInputPort("state", layout.size)
        self.command_port = self.DeclareAbstractInputPort("command", AbstractValue.Make(SpatialCommand(stamp=-1)))
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
        u[list(self.layout.actuation)] = (s.torque_pitch, s.torque_roll, s.force)
        output.SetFromVector(u)

    def raibert_direction(self, velocity, wanted, offset=(0.0, 0.0)) -> np.ndarray:
        """The world leg direction to the neutral point (half the stance's travel ahead of the hip along the
        horizontal ``velocity``) plus ``SPEED_GAIN`` times its error from ``wanted`` and the learned ``offset``:
        Raibert's placement."""
        gain = self.scaled.speed_gain
        ox = 0.5 * velocity[0] * self.scaled.stance_time + gain * (velocity[0] - wanted[0]) + offset[0]
        oy = 0.5 * velocity[1] * self.scaled.stance_time + gain * (velocity[1] - wanted[1]) + offset[1]
        return offset_direction(ox, oy, self.params.slip.leg_length, self.cone_reach)

    def _update(self, context, discrete_state):
        s = ControlState(discrete_state.get_mutable_vector(self.control_state).get_mutable_value())
        x = self.state_port.Eval(context)
        lay = self.layout
        r = rotation(*x[list(lay.quaternion)])
        sensed = Sensed(x[list(lay.position)], x[list(lay.linear)], x[list(lay.angular)], r, x[list(lay.hip)],
                        x[list(lay.hip_rates)], float(x[lay.leg]), float(x[lay.leg_rate]))
        command = self.command_port.Eval(context)
        t = context.get_time()
        if command.stamp != s.stamp:
            s.stamp, s.step = command.stamp, 0.0
            if s.phase == Phase.DESCENT:   # the command of the apex this descent began at
                self._hop_target(s, command, sensed)
        phase = self._next_phase(s, sensed, command, t)
        if phase != s.phase:
            s.phase, s.phase_start = phase, t
        if math.isnan(s.target):
            self._hop_target(s, command, sensed)
        if phase == Phase.STANCE:
            torques, force = self._stance_control(s, sensed)
        else:
            torques, force = self._flight_control(s, sensed, command, phase)
        s.torque_pitch = motor_torque(torques[0], sensed.hip_rates[0], self.params)
        s.torque_roll = motor_torque(torques[1], sensed.hip_rates[1], self.params)
        s.force = force

    def _next_phase(self, s: ControlState, sensed: Sensed, command: SpatialCommand, t: float) -> Phase:
        """The phase after this period's measurement: an apex (learning the energy it missed, taking the next
        target), a touchdown (counted, the foot's height and the lean for the stance recorded) or a liftoff."""
        position, velocity, _, r, hip, _, leg, leg_rate = sensed
        rest, g = self.params.rest_extension, self.params.slip.gravity
        phase = Phase(int(s.phase))
        if phase == Phase.ASCENT and velocity[2] <= 0.0:
            s.apexes += 1.0
            if s.floored:   # the push aimed at the floor's apex: what it missed of that
                s.bias += BIAS_GAIN * g * (s.touchdown_z + self.apex_floor - position[2])
            elif not math.isnan(s.target):
                kinetic = velocity @ velocity if s.total else 0.0
                s.bias += BIAS_GAIN * (s.target - g * position[2] - 0.5 * kinetic)
            s.floored = 0.0
            self._hop_target(s, command, sensed)
            if s.step >= len(command.footholds):
                u = units_of(self.params.slip)
                gain, most = OFFSET_GAIN * SPEED_GAIN * u.time, OFFSET_ERROR * u.speed
                s.offset_x += gain * max(-most, min(most, velocity[0] - command.velocity[0]))
                s.offset_y += gain * max(-most, min(most, velocity[1] - command.velocity[1]))
            return Phase.DESCENT
        if phase == Phase.DESCENT and rest - leg > self.scaled.touchdown_compression \
                and leg_rate < self.scaled.touchdown_rate:
            s.step += 1.0
            d = r @ leg_direction(*hip)
            s.touchdown_z = position[2] + leg * d[2] - self.params.foot_radius   # the ground under the ball
            # lean against the next flight's swing, which turns the body back by about twice the leg's angle
            # at touchdown (see the planar controller); in Drake's angles a forward foot is a negative pitch
            yaw = math.atan2(r[1, 0], r[0, 0])
            forward = math.cos(yaw) * d[0] + math.sin(yaw) * d[1]
            left = -math.sin(yaw) * d[0] + math.cos(yaw) * d[1]
            s.lean_roll = self.swing_ratio[0] * math.asin(max(-1.0, min(1.0, left)))
            s.lean_pitch = -self.swing_ratio[1] * math.atan2(forward, -d[2])
            return Phase.STANCE
        if phase == Phase.STANCE and t - s.phase_start > self.scaled.min_stance \
                and leg >= rest - self.scaled.liftoff_margin:
            return Phase.ASCENT
        return phase

    def _hop_target(self, s: ControlState, command: SpatialCommand, sensed: Sensed) -> None:
        """This hop's energy target from ``command`` at an apex (``sensed``): on a foothold, the total energy;
        past the footholds, the vertical energy of the apex height."""
        g, z, v = self.params.slip.gravity, sensed.position[2], sensed.velocity
        if s.step < len(command.footholds):
            s.total = 1.0
            s.target = command.energy if command.energy is not None else g * z + 0.5 * float(v[:2] @ v[:2])
        else:
            s.total = 0.0
            s.target = g * (command.apex_height if command.apex_height is not None else z)

    def _stance_control(self, s: ControlState, sensed: Sensed) -> tuple:
        """((hip pitch, hip roll) torques, leg force) in stance: attitude and angular momentum held, the leg pushing
        during extension until the body's vertical energy is that of this hop's apex height."""
        p = self.params
        slip, rest, g = p.slip, p.rest_extension, p.slip.gravity
        position, velocity, omega, r, hip, hip_rates, leg, leg_rate = sensed
        roll, pitch, yaw = roll_pitch_yaw(r)
        cy, sy = math.cos(yaw), math.sin(yaw)
        momentum = self.angular_momentum(velocity, omega, r, hip, hip_rates, leg, leg_rate)
        # errors and momentum about the heading's axes (forward, left), where roll and pitch turn the body
        h_forward, h_left = cy * momentum[0] + sy * momentum[1], -sy * momentum[0] + cy * momentum[1]
        kp, kd = self.scaled.stance_gains
        want_forward = -(kp * (roll - s.lean_roll) + kd * h_forward / self.inertia[0])
        want_left = -(kp * (pitch - s.lean_pitch) + kd * h_left / self.inertia[1])
        # the torque pushes the foot across the leg: it may take FRICTION_SHARE of the friction the leg's force,
        # tilted by the leg's angle from the vertical, leaves
        leg_force = slip.stiffness * max(rest - leg, 0.0)
        d = r @ leg_direction(*hip)
        cos, sin, mu = -d[2], math.hypot(d[0], d[1]), slip.friction
        cap = FRICTION_SHARE * leg_force * (leg + p.foot_radius) * max(mu * cos - sin, 0.0) / (cos + mu * sin)
        size = math.hypot(want_forward, want_left)
        if size > cap:
            want_forward, want_left = want_forward * cap / size, want_left * cap / size
        # the torque on the body, from the heading's axes to the body's; the pitch joint turns the body about its y,
        # the roll joint about the gimbal's x, (cos p, 0, sin p) in the body frame, the other way
        torque_body = r.T @ np.array([cy * want_forward - sy * want_left, sy * want_forward + cy * want_left, 0.0])
        torques = (torque_body[1], -torque_body[0] / max(math.cos(hip[0]), 0.2))
        force = 0.0
        if leg_rate > 0.0:
            spring = 0.5 * slip.stiffness * (rest - leg) ** 2 / slip.mass
            vertical = g * position[2] + 0.5 * velocity[2] ** 2 + spring
            speed2 = float(velocity @ velocity if s.total else velocity[2] ** 2)
            energy = vertical + 0.5 * (speed2 - velocity[2] ** 2)
            liftoff_loss = 0.5 * self.foot_share * speed2   # the foot jerked to the body's speed at liftoff
            need = s.target + liftoff_loss + s.bias - energy
            # at least the flight of an apex ``apex_floor`` above the leg standing on this foothold: the template's
            # massless leg swings through anywhere, the robot's needs room to lift its foot and swing it forward
            floor = g * (s.touchdown_z + self.apex_floor) + 0.5 * self.foot_share * velocity[2] ** 2 + s.bias
            s.floored = float(floor - vertical > need)
            need = max(need, floor - vertical)
            force = slip.mass * need / max(rest - leg, self.scaled.least_stroke)
            # taking energy out, the actuator pulls against at most half the spring's force: pulling harder unloads
            # the foot, which leaves the ground with the leg still compressed
            force = max(-0.5 * min(p.leg_force_limit, leg_force), min(p.leg_force_limit, force))
        return torques, force

    def _flight_control(self, s: ControlState, sensed: Sensed, command: SpatialCommand, phase: Phase) -> tuple:
        """((hip pitch, hip roll) torques, leg force) in flight: the hip turns the leg to the wanted world
        direction through the body's attitude; the leg retracts in ascent and extends to its stop in descent."""
        p = self.params
        position, velocity, omega, r, hip, hip_rates, leg, leg_rate = sensed
        rest = p.rest_extension
        step = int(s.step)
        if step >= len(command.footholds):
            wanted = self.raibert_direction(velocity, command.velocity, (s.offset_x, s.offset_y))
            # to the ground the last foot stood on
            fall = fall_time(position[2], velocity[2], position[2] + rest * wanted[2] - p.foot_radius - s.touchdown_z,
                             p.slip.gravity)
        elif phase == Phase.ASCENT:
            # the planner chooses the next foothold at the apex: the leg waits at the neutral point
            wanted, fall = self.raibert_direction(velocity, velocity), math.inf
        else:
            fx, fy, fz = command.footholds[step]
            wanted, fall = aim_direction(position, velocity, (fx, fy, fz + p.foot_radius), rest, p.slip.gravity)
        if phase == Phase.DESCENT:
            target, rate = self._landing_swing(wanted, fall, velocity, r)
        else:
            target, rate = hip_angles(r.T @ wanted), (0.0, 0.0)
        kp, kd = self.scaled.flight_gains
        if phase == Phase.ASCENT and self._foot_clearance(s, sensed, command, wanted) < self.scaled.clearance:
            # the foot is leaving the ground: the leg retracts and swings back at the rate that keeps the foot over
            # the ground it left (dragged forward, a foot near a face catches it and kicks the body round)
            kp, kd = 0.0, self.scaled.lift_damping
            d = r @ leg_direction(*hip)
            _, rate = self._moving_offset(r, leg * d[0], leg * d[1], -velocity[:2], leg)
        torques = (kp * (target[0] - hip[0]) + kd * (rate[0] - hip_rates[0]),
                   kp * (target[1] - hip[1]) + kd * (rate[1] - hip_rates[1]))
        goal = rest - self.scaled.retract if phase == Phase.ASCENT else rest + self.scaled.least_stroke
        kp, kd = self.scaled.leg_gains
        force = kp * (goal - leg) - kd * leg_rate - p.slip.stiffness * (rest - leg)
        return torques, max(-p.leg_force_limit, min(p.leg_force_limit, force))

    def _foot_clearance(self, s: ControlState, sensed: Sensed, command: SpatialCommand, wanted) -> float:
        """The foot ball's height above the highest ground between it and where the leg's swing to ``wanted`` takes it
        (without a map: above the ground it left)."""
        position, r, leg = sensed.position, sensed.rotation, sensed.leg
        foot = position + leg * (r @ leg_direction(*sensed.hip))
        bottom = foot[2] - self.params.foot_radius
        if command.heights is None:
            return bottom - s.touchdown_z
        reach = leg + self.params.foot_radius
        ground = command.heights.highest_along(foot[:2], (position[0] + reach * wanted[0],
                                                          position[1] + reach * wanted[1]))
        return bottom - (ground if ground > -math.inf else s.touchdown_z)

    def _landing_swing(self, wanted, fall: float, velocity, r) -> tuple:
        """(hip angles, their rates) that land the foot, ``fall`` seconds from now, where ``wanted`` points with it
        swinging back under the body
        at LANDING_SWING_SHARE of the body's horizontal speed: the hip leads by the swing still to come (at most
        LANDING_SWING_TIME's) and damps about the swing's rate. A foot landing at the body's speed slides before
        the leg's force holds it (ground-speed matching; the planar controller's)."""
        reach = self.params.rest_extension
        swing = -LANDING_SWING_SHARE * velocity[:2]
        lead = min(fall, self.scaled.landing_swing_time)
        return self._moving_offset(r, reach * wanted[0] - swing[0] * lead, reach * wanted[1] - swing[1] * lead, swing,
                                   reach)

    def _moving_offset(self, r, ox: float, oy: float, rate, reach: float) -> tuple:
        """(hip angles, their rates) of the leg whose foot, ``reach`` from the hip, lies (ox, oy) from it horizontally
        and moves by ``rate`` (x, y) [m/s] relative to it: the rates over one control period, through the body's
        attitude ``r``."""
        dt = self.params.time_step
        now = hip_angles(r.T @ offset_direction(ox, oy, reach))
        after = hip_angles(r.T @ offset_direction(ox + rate[0] * dt, oy + rate[1] * dt, reach))
        return now, ((after[0] - now[0]) / dt, (after[1] - now[1]) / dt)

    def angular_momentum(self, velocity, omega, r, hip, hip_rates, leg, leg_rate) -> np.ndarray:
        """The robot's angular momentum about its centre of mass [N m s], world frame: the body, the upper leg and the
        foot (turning with the leg), the gimbal's mass at the hip (its own inertia, 1e-4 of the body's, left out)."""
        p = self.params
        pitch, roll = hip
        d = r @ leg_direction(pitch, roll)
        gimbal_x = r @ np.array([math.cos(pitch), 0.0, math.sin(pitch)])
        omega_leg = omega + hip_rates[0] * (r @ np.array([0.0, -1.0, 0.0])) + hip_rates[1] * gimbal_x
        turn = cross(omega_leg, d)
        points = np.array([np.zeros(3), self.leg_com * d, leg * d])
        rates = np.array([np.zeros(3), self.leg_com * turn, leg * turn + leg_rate * d])
        masses = np.array([p.slip.mass + p.gimbal_mass, p.leg_mass, p.foot_mass])
        points -= masses @ points / masses.sum()
        rates -= masses @ rates / masses.sum()
        along = (omega_leg @ d) * d
        spin = (r @ (self.inertia * (r.T @ omega)) + self.leg_inertia[0] * (omega_leg - along)
                + self.leg_inertia[1] * along)
        return spin + sum(m * cross(q, v) for m, q, v in zip(masses, points, rates))
