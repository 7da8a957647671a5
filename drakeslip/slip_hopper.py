"""The SLIP hopper as a Drake hybrid system."""
from __future__ import annotations

import math

from pydrake.common.containers import namedview
from pydrake.systems.framework import EventStatus

from drakeslip import dynamics as dyn
from drakeslip.hybrid_hopper import FLIGHT, STANCE, ApexPolicy, HybridEvent, HybridHopper, Mode
from drakeslip.params import SlipParams
from drakeslip.state import ApexState, FailureMode, SimulationCrash
from drakeslip.terrain import Terrain

__all__ = ["SlipHopper", "ApexPolicy", "SlipState", "HybridState", "HybridEvent", "Mode"]

SlipState = namedview("SlipState", ["x", "z", "xdot", "zdot"])
HybridState = namedview("HybridState", ["mode", "leg_deployed", "leg_angle", "foot_x", "foot_z", "failure", "hops"])


class SlipHopper(HybridHopper):
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

    Guards (witness functions, ``drakeslip.hybrid_hopper``): touchdown (foot clearance), body_collision (body
    clearance), liftoff (leg back at rest length), apex (vertical velocity), bottom_out, slip (friction cone), stall
    (forward velocity). A foot that reaches the terrain through a vertical face, or reaches a ditch floor, is a
    FOOT_COLLISION; a commanded foot position that is not above the terrain at apex is a TRIP.
    """

    BODY, HYBRID = SlipState, HybridState

    def __init__(self, params: SlipParams | None = None, terrain: Terrain | None = None):
        self.params = params or SlipParams()
        self.terrain = terrain or Terrain.flat()
        self._p = self.params.as_array()
        self._h = self.terrain.heights
        super().__init__("leg_angle", 1)

    def set_apex(self, context, apex) -> None:
        """Put the hopper at an apex (x, z, xdot), in flight with the leg retracted and an empty log."""
        x, z, xdot = map(float, apex)
        self.start_at(context, [x, z, xdot, 0.0])

    def apex_of(self, s) -> ApexState:
        """The apex the body state ``s`` (a SlipState) is at."""
        return ApexState(s.x, s.z, s.xdot)

    def foot(self, h) -> tuple:
        return h.foot_x, h.foot_z

    def leg_command(self, h) -> float:
        return float(h.leg_angle)

    # ---- dynamics -------------------------------------------------------------------------------------
    def DoCalcTimeDerivatives(self, context, derivatives):
        s = self.body(context)
        h = self.hybrid(context)
        mode = int(h.mode)
        if mode == STANCE:
            d = dyn.stance_derivatives(s.x, s.z, s.xdot, s.zdot, h.foot_x, h.foot_z, self._p)
        elif mode == FLIGHT:
            d = (s.xdot, s.zdot, 0.0, -self.params.gravity)  # ballistic: only gravity acts on the body
        else:
            d = (0.0, 0.0, 0.0, 0.0)  # FAILED / HALTED: frozen
        if not (math.isfinite(d[0]) and math.isfinite(d[1]) and math.isfinite(d[2]) and math.isfinite(d[3])):
            # an error-controlled integrator would shrink its step for ever on them: stop the run, saying where
            raise SimulationCrash(f"non-finite derivatives ({', '.join(f'{v:g}' for v in d)}) in {Mode(mode).name} "
                                  f"at t={context.get_time():.6g} s, state ({', '.join(f'{v:g}' for v in s[:])})")
        derivatives.get_mutable_vector().SetFromVector(d)

    # ---- guards -----------------------------------------------------------------------------------------
    def foot_clearance(self, context):
        s, h = self.body(context), self.hybrid(context)
        return dyn.foot_clearance(s.x, s.z, h.leg_angle, self._p, self._h, self.terrain.x0, self.terrain.cell)

    def body_clearance(self, context):
        s = self.body(context)
        return dyn.body_clearance(s.x, s.z, self._h, self.terrain.x0, self.terrain.cell)

    def leg_extension(self, context):
        s, h = self.body(context), self.hybrid(context)
        return dyn.leg_extension(s.x, s.z, h.foot_x, h.foot_z, self._p)

    def stroke_left(self, context):
        s, h = self.body(context), self.hybrid(context)
        return dyn.stroke_left(s.x, s.z, h.foot_x, h.foot_z, self._p)

    def friction_margin(self, context):
        s, h = self.body(context), self.hybrid(context)
        return dyn.friction_margin(s.x, s.z, h.foot_x, h.foot_z, self._p)

    def progress(self, context):
        return self.body(context).xdot

    # ---- reset maps -------------------------------------------------------------------------------------
    def apex(self, context, event, state, record=True):
        """Apex (zdot = 0): sample the leg-angle command and swing the leg there, foot at
        (x + L0 sin th, z - L0 cos th); a foot that would not be above the terrain is a TRIP."""
        s, h = self.body(context), self.hybrid(context)
        if record:
            self.record(context, state, "apex", s, None, float(h.leg_angle))
        command = float(self.get_input_port(0).Eval(context)[0]) if self.get_input_port(0).HasValue(context) \
            else math.nan
        if math.isnan(command):
            h.mode = Mode.HALTED
        else:
            h.leg_angle = command
            h.leg_deployed = 1
            if dyn.foot_clearance(s.x, s.z, command, self._p, self._h, self.terrain.x0, self.terrain.cell) <= 0:
                return self.fail(context, state, h, FailureMode.TRIP)
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
            return self.fail(context, state, h, FailureMode.FOOT_COLLISION)
        self.record(context, state, "touchdown", s, (fx, fz), float(h.leg_angle))
        if dyn.friction_margin(s.x, s.z, fx, fz, self._p) < 0:
            return self.fail(context, state, h, FailureMode.SLIP)
        if dyn.leg_rate(s.x, s.z, s.xdot, s.zdot, fx, fz) >= 0:
            return self.fail(context, state, h, FailureMode.STALL)
        h.mode = Mode.STANCE
        state.get_mutable_discrete_state().get_mutable_vector().SetFromVector(h[:])
        return EventStatus.Succeeded()

    def liftoff(self, context, event, state):
        """Liftoff (leg back at rest length): the foot leaves the ground and the leg retracts; the body state
        is continuous. With no upward velocity there is no apex to come: STALL."""
        s, h = self.body(context), self.hybrid(context)
        self.record(context, state, "liftoff", s, (h.foot_x, h.foot_z), float(h.leg_angle))
        if s.zdot <= 0 or s.xdot <= 0:
            return self.fail(context, state, h, FailureMode.STALL)
        h.mode = Mode.FLIGHT
        h.leg_deployed = 0
        h.hops += 1
        state.get_mutable_discrete_state().get_mutable_vector().SetFromVector(h[:])
        return EventStatus.Succeeded()
