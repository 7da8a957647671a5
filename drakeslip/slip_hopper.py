"""The SLIP hopper as a Drake hybrid system."""
from __future__ import annotations

import enum
import math
from typing import NamedTuple

import numpy as np
from pydrake.common.containers import namedview
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import (BasicVector, EventStatus, LeafSystem, UnrestrictedUpdateEvent,
                                       WitnessFunctionDirection)

from drakeslip import dynamics as dyn
from drakeslip.params import SlipParams
from drakeslip.state import ApexState, FailureMode, SimulationCrash
from drakeslip.terrain import Terrain

SlipState = namedview("SlipState", ["x", "z", "xdot", "zdot"])
HybridState = namedview("HybridState", ["mode", "leg_deployed", "leg_angle", "foot_x", "foot_z", "failure", "hops"])


class Mode(enum.IntEnum):
    FLIGHT = 0
    STANCE = 1
    FAILED = 2  # stopped at the first failure (HybridState.failure says which)
    HALTED = 3  # the leg-angle command at an apex was NaN: no further hop was asked for


# Plain ints for the hot paths (derivatives and witness selection run thousands of times per hop).
_FLIGHT, _STANCE = int(Mode.FLIGHT), int(Mode.STANCE)
_MODE, _LEG_DEPLOYED = HybridState._fields.index("mode"), HybridState._fields.index("leg_deployed")


class HybridEvent(NamedTuple):
    """One entry of the event log: kind is 'apex', 'touchdown', 'liftoff' or 'failure'."""

    kind: str
    time: float
    state: tuple          # (x, z, xdot, zdot) at the event
    foot: tuple | None    # (x, z) of the foot, where it is defined
    leg_angle: float
    failure: FailureMode | None = None


class SlipHopper(LeafSystem):
    """Planar spring-loaded inverted pendulum hopping over a piecewise-constant Terrain.

    State
      continuous (SlipState): x, z, xdot, zdot — the body, world frame.
      discrete (HybridState): mode (Mode), leg_deployed (1 after the apex placement, 0 after liftoff),
        leg_angle (held from apex to touchdown), foot_x, foot_z (pinned in stance), failure (FailureMode code,
        0 = none), hops (liftoffs so far: at an apex, the index of the hop its command is for; counted at
        liftoff because the apex command is read from the pre-event context).
      abstract: the event log, a tuple of HybridEvent.
    Input port
      leg_angle (1): the commanded leg angle [rad from vertical, + = foot ahead], sampled at each apex
      (and at initialization, where the simulation starts at an apex). NaN halts the hopper.
    Output ports
      state (4): SlipState.   hybrid (7): HybridState.
    Parameters
      SlipParams and Terrain, fixed at construction; everything that changes lives in the Context, so one
      system can be simulated in many contexts.

    Guards (witness functions): touchdown (foot clearance), body_collision (body clearance), liftoff (leg back
    at rest length), apex (vertical velocity), bottom_out, slip (friction cone), stall (forward velocity).
    A foot that reaches the terrain through a vertical face, or reaches a ditch floor, is a FOOT_COLLISION;
    a commanded foot position that is not above the terrain at apex is a TRIP.
    """

    def __init__(self, params: SlipParams | None = None, terrain: Terrain | None = None):
        super().__init__()
        self.params = params or SlipParams()
        self.terrain = terrain or Terrain.flat()
        self._p = self.params.as_array()
        self._h = self.terrain.heights
        self.DeclareVectorInputPort("leg_angle", 1)
        xc = self.DeclareContinuousState(4)
        xd = self.DeclareDiscreteState(len(HybridState._fields))
        self._log_index = self.DeclareAbstractState(AbstractValue.Make(()))
        self.DeclareStateOutputPort("state", xc)
        self.DeclareStateOutputPort("hybrid", xd)
        self.DeclareInitializationUnrestrictedUpdateEvent(self._initial_apex)

        direction = WitnessFunctionDirection
        self._touchdown = self.MakeWitnessFunction(
            "touchdown", direction.kPositiveThenNonPositive, self._foot_clearance,
            UnrestrictedUpdateEvent(self.touchdown))
        self._body_collision = self.MakeWitnessFunction(
            "body_collision", direction.kPositiveThenNonPositive, self._body_clearance,
            UnrestrictedUpdateEvent(self._failure_handler(FailureMode.BODY_COLLISION)))
        self._liftoff = self.MakeWitnessFunction(
            "liftoff", direction.kNegativeThenNonNegative, self._leg_extension,
            UnrestrictedUpdateEvent(self.liftoff))
        self._apex = self.MakeWitnessFunction(
            "apex", direction.kPositiveThenNonPositive, self._vertical_velocity,
            UnrestrictedUpdateEvent(self.apex))
        self._bottom_out = self.MakeWitnessFunction(
            "bottom_out", direction.kPositiveThenNonPositive, self._stroke_left,
            UnrestrictedUpdateEvent(self._failure_handler(FailureMode.BOTTOM_OUT)))
        self._slip = self.MakeWitnessFunction(
            "slip", direction.kPositiveThenNonPositive, self._friction_margin,
            UnrestrictedUpdateEvent(self._failure_handler(FailureMode.SLIP)))
        self._stall = self.MakeWitnessFunction(
            "stall", direction.kPositiveThenNonPositive, self._forward_velocity,
            UnrestrictedUpdateEvent(self._failure_handler(FailureMode.STALL)))
        self._stance_guards = [self._liftoff, self._body_collision, self._bottom_out, self._slip, self._stall]
        self._descent_guards = [self._touchdown, self._body_collision]
        self._ascent_guards = [self._apex, self._body_collision]

    # ---- context helpers ------------------------------------------------------------------------------
    def set_apex(self, context, apex) -> None:
        """Put the hopper at an apex (x, z, xdot), in flight with the leg retracted and an empty log."""
        x, z, xdot = map(float, apex)
        context.SetContinuousState([x, z, xdot, 0.0])
        hybrid = HybridState(np.zeros(len(HybridState._fields)))
        hybrid.mode = Mode.FLIGHT
        context.SetDiscreteState(hybrid[:])
        context.SetAbstractState(self._log_index, ())

    def body(self, context) -> SlipState:
        return SlipState(context.get_continuous_state_vector().CopyToVector())

    def hybrid(self, context) -> HybridState:
        return HybridState(context.get_discrete_state_vector().CopyToVector())

    def event_log(self, context) -> tuple:
        return context.get_abstract_state(self._log_index).get_value()

    # ---- dynamics -------------------------------------------------------------------------------------
    def DoCalcTimeDerivatives(self, context, derivatives):
        s = self.body(context)
        h = self.hybrid(context)
        mode = int(h.mode)
        if mode == _STANCE:
            d = dyn.stance_derivatives(s.x, s.z, s.xdot, s.zdot, h.foot_x, h.foot_z, self._p)
        elif mode == _FLIGHT:
            d = (s.xdot, s.zdot, 0.0, -self.params.gravity)  # ballistic: only gravity acts on the body
        else:
            d = (0.0, 0.0, 0.0, 0.0)  # FAILED / HALTED: frozen
        if not (math.isfinite(d[0]) and math.isfinite(d[1]) and math.isfinite(d[2]) and math.isfinite(d[3])):
            # an error-controlled integrator would shrink its step for ever on them: stop the run, saying where
            raise SimulationCrash(f"non-finite derivatives ({', '.join(f'{v:g}' for v in d)}) in {Mode(mode).name} "
                                  f"at t={context.get_time():.6g} s, state ({', '.join(f'{v:g}' for v in s[:])})")
        derivatives.get_mutable_vector().SetFromVector(d)

    def DoGetWitnessFunctions(self, context):
        h = context.get_discrete_state_vector()
        mode = int(h.GetAtIndex(_MODE))
        if mode == _STANCE:
            return self._stance_guards
        if mode == _FLIGHT:
            return self._descent_guards if h.GetAtIndex(_LEG_DEPLOYED) else self._ascent_guards
        return []

    # ---- guards -----------------------------------------------------------------------------------------
    def _foot_clearance(self, context):
        s, h = self.body(context), self.hybrid(context)
        return dyn.foot_clearance(s.x, s.z, h.leg_angle, self._p, self._h, self.terrain.x0, self.terrain.cell)

    def _body_clearance(self, context):
        s = self.body(context)
        return dyn.body_clearance(s.x, s.z, self._h, self.terrain.x0, self.terrain.cell)

    def _leg_extension(self, context):
        s, h = self.body(context), self.hybrid(context)
        return dyn.leg_extension(s.x, s.z, h.foot_x, h.foot_z, self._p)

    def _stroke_left(self, context):
        s, h = self.body(context), self.hybrid(context)
        return dyn.stroke_left(s.x, s.z, h.foot_x, h.foot_z, self._p)

    def _friction_margin(self, context):
        s, h = self.body(context), self.hybrid(context)
        return dyn.friction_margin(s.x, s.z, h.foot_x, h.foot_z, self._p)

    def _vertical_velocity(self, context):
        return self.body(context).zdot

    def _forward_velocity(self, context):
        return self.body(context).xdot

    # ---- reset maps -------------------------------------------------------------------------------------
    def _initial_apex(self, context, state):
        return self.apex(context, None, state, record=False)

    def apex(self, context, event, state, record=True):
        """Apex (zdot = 0): sample the leg-angle command and swing the leg there, foot at
        (x + L0 sin th, z - L0 cos th); a foot that would not be above the terrain is a TRIP."""
        s, h = self.body(context), self.hybrid(context)
        if record:
            self._record(context, state, "apex", s, None, h.leg_angle)
        command = float(self.get_input_port(0).Eval(context)[0]) if self.get_input_port(0).HasValue(context) \
            else math.nan
        if math.isnan(command):
            h.mode = Mode.HALTED
        else:
            h.leg_angle = command
            h.leg_deployed = 1
            if dyn.foot_clearance(s.x, s.z, command, self._p, self._h, self.terrain.x0, self.terrain.cell) <= 0:
                return self._fail(context, state, h, FailureMode.TRIP)
        state.get_mutable_discrete_state().get_mutable_vector().SetFromVector(h[:])
        return EventStatus.Succeeded()

    def touchdown(self, context, event, state):
        """Touchdown: pin the foot where it met the terrain, (xf, zf) = (x + L0 sin th, z - L0 cos th); the body
        state is continuous. A face strike or ditch is a FOOT_COLLISION; a touchdown outside the friction cone
        is a SLIP, and a leg that is already extending cannot load (STALL)."""
        s, h = self.body(context), self.hybrid(context)
        fx, fz = dyn.foot_position(s.x, s.z, h.leg_angle, self._p)
        h.foot_x, h.foot_z = fx, fz
        ground = dyn.height_at(self._h, self.terrain.x0, self.terrain.cell, fx)
        if dyn.classify_foot_contact(fz, ground, self.terrain.ditch_height) != 0:
            return self._fail(context, state, h, FailureMode.FOOT_COLLISION)
        self._record(context, state, "touchdown", s, (fx, fz), h.leg_angle)
        if dyn.friction_margin(s.x, s.z, fx, fz, self._p) < 0:
            return self._fail(context, state, h, FailureMode.SLIP)
        if dyn.leg_rate(s.x, s.z, s.xdot, s.zdot, fx, fz) >= 0:
            return self._fail(context, state, h, FailureMode.STALL)
        h.mode = Mode.STANCE
        state.get_mutable_discrete_state().get_mutable_vector().SetFromVector(h[:])
        return EventStatus.Succeeded()

    def liftoff(self, context, event, state):
        """Liftoff (leg back at rest length): the foot leaves the ground and the leg retracts; the body state
        is continuous. With no upward velocity there is no apex to come: STALL."""
        s, h = self.body(context), self.hybrid(context)
        self._record(context, state, "liftoff", s, (h.foot_x, h.foot_z), h.leg_angle)
        if s.zdot <= 0 or s.xdot <= 0:
            return self._fail(context, state, h, FailureMode.STALL)
        h.mode = Mode.FLIGHT
        h.leg_deployed = 0
        h.hops += 1
        state.get_mutable_discrete_state().get_mutable_vector().SetFromVector(h[:])
        return EventStatus.Succeeded()

    def _failure_handler(self, mode: FailureMode):
        def handler(context, event, state):
            return self._fail(context, state, self.hybrid(context), mode)
        return handler

    def _fail(self, context, state, h, mode: FailureMode):
        """Any failure: freeze the hopper where it is and log which failure, when and where."""
        s = self.body(context)
        foot = (h.foot_x, h.foot_z) if h.mode == Mode.STANCE else None
        self._record(context, state, "failure", s, foot, h.leg_angle, mode)
        h.mode = Mode.FAILED
        h.failure = int(mode)
        state.get_mutable_discrete_state().get_mutable_vector().SetFromVector(h[:])
        return EventStatus.Succeeded()

    def _record(self, context, state, kind, s, foot, leg_angle, failure=None):
        log = state.get_abstract_state().get_value(self._log_index).get_value()
        entry = HybridEvent(kind, context.get_time(), tuple(float(v) for v in s[:]), foot, float(leg_angle), failure)
        state.get_mutable_abstract_state().get_mutable_value(self._log_index).set_value(log + (entry,))


class ApexPolicy(LeafSystem):
    """Leg-angle source for SlipHopper: ``policy(apex, hop_index) -> angle or None`` evaluated when the hopper
    samples its input at an apex. None (or running out of commands) halts the hopper."""

    def __init__(self, policy):
        super().__init__()
        self._policy = policy
        self._state = self.DeclareVectorInputPort("state", 4)
        self._hybrid = self.DeclareVectorInputPort("hybrid", len(HybridState._fields))
        self.DeclareVectorOutputPort("leg_angle", 1, self._calc)

    def _calc(self, context, output: BasicVector):
        s = SlipState(self._state.Eval(context))
        hops = int(HybridState(self._hybrid.Eval(context)).hops)
        angle = self._policy(ApexState(s.x, s.z, s.xdot), hops)
        output.SetAtIndex(0, math.nan if angle is None else float(angle))
