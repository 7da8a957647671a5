"""What the planar and the spatial SLIP share as Drake hybrid systems: the modes, the event log, the guards' wiring
and the failure handling. ``drakeslip.slip_hopper.SlipHopper`` and ``drakeslip.spatial.slip_hopper.SlipHopper3D``
supply the physics: the derivatives, each guard's function and the apex, touchdown and liftoff reset maps."""
from __future__ import annotations

import enum
import math
from typing import NamedTuple

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import (BasicVector, EventStatus, LeafSystem, UnrestrictedUpdateEvent,
                                       WitnessFunctionDirection)

from drakeslip.state import FailureMode


class Mode(enum.IntEnum):
    FLIGHT = 0
    STANCE = 1
    FAILED = 2  # stopped at the first failure (the hybrid state's failure says which)
    HALTED = 3  # the leg command at an apex was NaN: no further hop was asked for


# Plain ints for the hot paths (derivatives and witness selection run thousands of times per hop); every hybrid
# state starts with (mode, leg_deployed).
FLIGHT, STANCE = int(Mode.FLIGHT), int(Mode.STANCE)
MODE_INDEX, LEG_DEPLOYED_INDEX = 0, 1


class HybridEvent(NamedTuple):
    """One entry of the event log: kind is 'apex', 'touchdown', 'liftoff' or 'failure'."""

    kind: str
    time: float
    state: tuple          # the body's state at the event
    foot: tuple | None    # the foot's position, where it is defined
    leg_angle: float | tuple   # the leg command held then: an angle (planar) or (pitch, roll) (spatial)
    failure: FailureMode | None = None


class HybridHopper(LeafSystem):
    """A SLIP hopper's hybrid machinery (see the module doc). A subclass sets ``BODY`` and ``HYBRID`` (namedviews
    of its continuous and discrete state; ``HYBRID`` starts with mode and leg_deployed and has ``failure`` and
    ``hops``), calls ``__init__`` with its input port's name and size, and defines the guard functions
    (``foot_clearance``, ``body_clearance``, ``leg_extension``, ``stroke_left``, ``friction_margin``, ``progress``;
    ``vertical_velocity`` is here), the reset maps (``apex``, ``touchdown``, ``liftoff``), ``apex_of(body)``,
    ``foot(h)`` and ``leg_command(h)``."""

    BODY = None
    HYBRID = None

    def __init__(self, command_port: str, command_size: int):
        super().__init__()
        self.DeclareVectorInputPort(command_port, command_size)
        xc = self.DeclareContinuousState(len(self.BODY._fields))
        xd = self.DeclareDiscreteState(len(self.HYBRID._fields))
        self._log_index = self.DeclareAbstractState(AbstractValue.Make(()))
        self.DeclareStateOutputPort("state", xc)
        self.DeclareStateOutputPort("hybrid", xd)
        self.DeclareInitializationUnrestrictedUpdateEvent(self._initial_apex)

        def witness(name, direction, guard, handler):
            return self.MakeWitnessFunction(name, direction, guard, UnrestrictedUpdateEvent(handler))

        down, up = WitnessFunctionDirection.kPositiveThenNonPositive, WitnessFunctionDirection.kNegativeThenNonNegative
        touchdown = witness("touchdown", down, self.foot_clearance, self.touchdown)
        body_collision = witness("body_collision", down, self.body_clearance,
                                 self.failure_handler(FailureMode.BODY_COLLISION))
        liftoff = witness("liftoff", up, self.leg_extension, self.liftoff)
        apex = witness("apex", down, self.vertical_velocity, self.apex)
        bottom_out = witness("bottom_out", down, self.stroke_left, self.failure_handler(FailureMode.BOTTOM_OUT))
        slip = witness("slip", down, self.friction_margin, self.failure_handler(FailureMode.SLIP))
        stall = witness("stall", down, self.progress, self.failure_handler(FailureMode.STALL))
        self._stance_guards = [liftoff, body_collision, bottom_out, slip, stall]
        self._descent_guards = [touchdown, body_collision]
        self._ascent_guards = [apex, body_collision]

    # ---- context helpers ------------------------------------------------------------------------------
    def start_at(self, context, body) -> None:
        """Put the hopper in flight with the body state ``body``, the leg retracted and an empty log."""
        context.SetContinuousState(body)
        hybrid = self.HYBRID(np.zeros(len(self.HYBRID._fields)))
        hybrid.mode = Mode.FLIGHT
        context.SetDiscreteState(hybrid[:])
        context.SetAbstractState(self._log_index, ())

    def body(self, context):
        return self.BODY(context.get_continuous_state_vector().CopyToVector())

    def hybrid(self, context):
        return self.HYBRID(context.get_discrete_state_vector().CopyToVector())

    def event_log(self, context) -> tuple:
        return context.get_abstract_state(self._log_index).get_value()

    def DoGetWitnessFunctions(self, context):
        h = context.get_discrete_state_vector()
        mode = int(h.GetAtIndex(MODE_INDEX))
        if mode == STANCE:
            return self._stance_guards
        if mode == FLIGHT:
            return self._descent_guards if h.GetAtIndex(LEG_DEPLOYED_INDEX) else self._ascent_guards
        return []

    def vertical_velocity(self, context):
        return self.body(context).zdot

    # ---- events -------------------------------------------------------------------------------------------
    def _initial_apex(self, context, state):
        return self.apex(context, None, state, record=False)

    def failure_handler(self, mode: FailureMode):
        def handler(context, event, state):
            return self.fail(context, state, self.hybrid(context), mode)
        return handler

    def fail(self, context, state, h, mode: FailureMode):
        """Any failure: freeze the hopper where it is and log which failure, when and where."""
        s = self.body(context)
        foot = self.foot(h) if h.mode == Mode.STANCE else None
        self.record(context, state, "failure", s, foot, self.leg_command(h), mode)
        h.mode = Mode.FAILED
        h.failure = int(mode)
        state.get_mutable_discrete_state().get_mutable_vector().SetFromVector(h[:])
        return EventStatus.Succeeded()

    def record(self, context, state, kind, s, foot, leg_command, failure=None):
        log = state.get_abstract_state().get_value(self._log_index).get_value()
        entry = HybridEvent(kind, context.get_time(), tuple(float(v) for v in s[:]), foot, leg_command, failure)
        state.get_mutable_abstract_state().get_mutable_value(self._log_index).set_value(log + (entry,))


class ApexPolicy(LeafSystem):
    """The leg command source of a hopper: ``policy(apex, hop_index)`` is called when the hopper samples its input
    at an apex and returns its leg command (the planar hopper's angle, the spatial hopper's (pitch, roll)) or None.
    None (or running out of commands) halts the hopper."""

    def __init__(self, policy, hopper: HybridHopper):
        super().__init__()
        self._policy = policy
        self._hopper = hopper
        self._state = self.DeclareVectorInputPort("state", len(hopper.BODY._fields))
        self._hybrid = self.DeclareVectorInputPort("hybrid", len(hopper.HYBRID._fields))
        self._size = hopper.get_input_port(0).size()
        self.DeclareVectorOutputPort(hopper.get_input_port(0).get_name(), self._size, self._calc)

    def _calc(self, context, output: BasicVector):
        s = self._hopper.BODY(self._state.Eval(context))
        hops = int(self._hopper.HYBRID(self._hybrid.Eval(context)).hops)
        command = self._policy(self._hopper.apex_of(s), hops)
        if command is None:
            output.SetFromVector(np.full(self._size, math.nan))
        elif self._size == 1:
            output.SetAtIndex(0, float(command))
        else:
            output.SetFromVector(np.asarray(command, dtype=np.float64))
