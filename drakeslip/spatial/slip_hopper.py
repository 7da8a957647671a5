"""The spatial SLIP hopper as a Drake hybrid system, hopping on a height map."""
from __future__ import annotations

import math
from pydrake.common.containers import namedview
from pydrake.systems.framework import EventStatus

from drakeslip.dynamics import classify_foot_contact
from drakeslip.hybrid_hopper import FLIGHT, STANCE, HybridHopper, Mode
from drakeslip.params import SlipParams
from drakeslip.spatial import dynamics as dyn
from drakeslip.spatial.heightmap import HeightMap
from drakeslip.spatial.state import ApexState3D
from drakeslip.state import FailureMode, SimulationCrash

SlipState3D = namedview("SlipState3D", ["x", "y", "z", "xdot", "ydot", "zdot"])
HybridState3D = namedview("HybridState3D", ["mode", "leg_deployed", "leg_pitch", "leg_roll", "foot_x", "foot_y",
                                            "foot_z", "heading_x", "heading_y", "failure", "hops"])


class SlipHopper3D(HybridHopper):
    """Spatial spring-loaded inverted pendulum hopping on a HeightMap: a point mass on a massless spring leg.

    State
      continuous (SlipState3D): x, y, z, xdot, ydot, zdot — the body, world frame, z up.
      discrete (HybridState3D): mode (Mode), leg_deployed (1 after the apex placement, 0 after liftoff),
        leg_pitch, leg_roll (the touchdown direction, held from apex to touchdown: ``drakeslip.spatial.dynamics``),
        foot_x, foot_y, foot_z (pinned in stance), heading_x, heading_y (the unit horizontal velocity at the hop's
        apex, along which its progress is measured), failure (FailureMode code, 0 = none), hops (liftoffs so far).
      abstract: the event log, a tuple of HybridEvent (``leg_angle`` holds (pitch, roll)).
    Input port
      leg_angles (2): (pitch, roll) [rad], sampled at each apex (and at initialization, where a simulation starts
      at an apex). NaN halts the hopper.
    Output ports
      state (6): SlipState3D.   hybrid (11): HybridState3D.
    Parameters
      SlipParams and HeightMap, fixed at construction; everything that changes lives in the Context.

    Guards (witness functions): touchdown (foot clearance above the cell under the foot), body_collision (body
    clearance), liftoff (leg back at rest length), apex (vertical velocity), bottom_out, slip (friction cone), stall
    (progress along the heading). A foot that reaches the map through a cell's face, or in a hole, is a
    FOOT_COLLISION; a commanded foot that is not above the map at apex is a TRIP; an apex with no horizontal speed
    is a STALL. With no lateral motion and roll 0 on a map that does not vary in y it is ``SlipHopper``.
    """

    BODY, HYBRID = SlipState3D, HybridState3D

    def __init__(self, params: SlipParams | None = None, height_map: HeightMap | None = None):
        self.params = params or SlipParams()
        self.height_map = height_map or HeightMap.flat()
        self._p = self.params.as_array()
        self._ground = self.height_map.ground()
        super().__init__("leg_angles", 2)

    def set_apex(self, context, apex) -> None:
        """Put the hopper at an apex (x, y, z, xdot, ydot), in flight with the leg retracted and an empty log."""
        x, y, z, xdot, ydot = map(float, apex)
        self.start_at(context, [x, y, z, xdot, ydot, 0.0])

    def apex_of(self, s) -> ApexState3D:
        return ApexState3D(s.x, s.y, s.z, s.xdot, s.ydot)

    def foot(self, h) -> tuple:
        return h.foot_x, h.foot_y, h.foot_z

    def leg_command(self, h) -> tuple:
        return float(h.leg_pitch), float(h.leg_roll)

    # ---- dynamics -------------------------------------------------------------------------------------
    def DoCalcTimeDerivatives(self, context, derivatives):
        s = self.body(context)
        h = self.hybrid(context)
        mode = int(h.mode)
        if mode == STANCE:
            d = dyn.stance_derivatives(tuple(s[:]), h.foot_x, h.foot_y, h.foot_z, self._p)
        elif mode == FLIGHT:
            d = (s.xdot, s.ydot, s.zdot, 0.0, 0.0, -self.params.gravity)
        else:
            d = (0.0,) * 6  # FAILED / HALTED: frozen
        if not all(math.isfinite(v) for v in d):
            raise SimulationCrash(f"non-finite derivatives ({', '.join(f'{v:g}' for v in d)}) in {Mode(mode).name} "
                                  f"at t={context.get_time():.6g} s, state ({', '.join(f'{v:g}' for v in s[:])})")
        derivatives.get_mutable_vector().SetFromVector(d)

    # ---- guards -----------------------------------------------------------------------------------------
    def foot_clearance(self, context):
        s, h = self.body(context), self.hybrid(context)
        return dyn.foot_clearance(s.x, s.y, s.z, h.leg_pitch, h.leg_roll, self._p, self._ground)

    def body_clearance(self, context):
        s = self.body(context)
        return dyn.body_clearance(s.x, s.y, s.z, self._ground)

    def leg_extension(self, context):
        s, h = self.body(context), self.hybrid(context)
        return dyn.leg_extension(s.x, s.y, s.z, h.foot_x, h.foot_y, h.foot_z, self._p)

    def stroke_left(self, context):
        s, h = self.body(context), self.hybrid(context)
        return dyn.stroke_left(s.x, s.y, s.z, h.foot_x, h.foot_y, h.foot_z, self._p)

    def friction_margin(self, context):
        s, h = self.body(context), self.hybrid(context)
        return dyn.friction_margin(s.x, s.y, s.z, h.foot_x, h.foot_y, h.foot_z, self._p)

    def progress(self, context):
        s, h = self.body(context), self.hybrid(context)
        return dyn.progress(s.xdot, s.ydot, h.heading_x, h.heading_y)

    # ---- reset maps -------------------------------------------------------------------------------------
    def apex(self, context, event, state, record=True):
        """Apex (zdot = 0): sample the leg command and swing the leg there; the hop's heading is the horizontal
        velocity now. A foot that would not be above the map is a TRIP; no horizontal speed is a STALL."""
        s, h = self.body(context), self.hybrid(context)
        if record:
            self.record(context, state, "apex", s, None, self.leg_command(h))
        port = self.get_input_port(0)
        command = port.Eval(context) if port.HasValue(context) else (math.nan, math.nan)
        if math.isnan(command[0]) or math.isnan(command[1]):
            h.mode = Mode.HALTED
        else:
            h.leg_pitch, h.leg_roll = float(command[0]), float(command[1])
            h.leg_deployed = 1
            h.heading_x, h.heading_y = dyn.heading_of(s.xdot, s.ydot)
            if h.heading_x == 0.0 and h.heading_y == 0.0:
                return self.fail(context, state, h, FailureMode.STALL)
            if dyn.foot_clearance(s.x, s.y, s.z, h.leg_pitch, h.leg_roll, self._p, self._ground) <= 0:
                return self.fail(context, state, h, FailureMode.TRIP)
        state.get_mutable_discrete_state().get_mutable_vector().SetFromVector(h[:])
        return EventStatus.Succeeded()

    def touchdown(self, context, event, state):
        """Touchdown: pin the foot where it met the map; the body state is continuous. A face strike or a hole is a
        FOOT_COLLISION; a touchdown outside the friction cone is a SLIP, and a leg that is already extending cannot
        load (STALL)."""
        s, h = self.body(context), self.hybrid(context)
        fx, fy, fz = dyn.foot_position(s.x, s.y, s.z, h.leg_pitch, h.leg_roll, self._p)
        h.foot_x, h.foot_y, h.foot_z = fx, fy, fz
        ground = dyn.height_at(fx, fy, self._ground)
        if classify_foot_contact(fz, ground, self._ground.ditch_height) != 0:
            return self.fail(context, state, h, FailureMode.FOOT_COLLISION)
        self.record(context, state, "touchdown", s, (fx, fy, fz), self.leg_command(h))
        if dyn.friction_margin(s.x, s.y, s.z, fx, fy, fz, self._p) < 0:
            return self.fail(context, state, h, FailureMode.SLIP)
        if dyn.leg_rate(tuple(s[:]), fx, fy, fz) >= 0:
            return self.fail(context, state, h, FailureMode.STALL)
        h.mode = Mode.STANCE
        state.get_mutable_discrete_state().get_mutable_vector().SetFromVector(h[:])
        return EventStatus.Succeeded()

    def liftoff(self, context, event, state):
        """Liftoff (leg back at rest length): the foot leaves the ground and the leg retracts. With no upward
        velocity, or no progress along the heading, there is no apex to come: STALL."""
        s, h = self.body(context), self.hybrid(context)
        self.record(context, state, "liftoff", s, self.foot(h), self.leg_command(h))
        if s.zdot <= 0 or dyn.progress(s.xdot, s.ydot, h.heading_x, h.heading_y) <= 0:
            return self.fail(context, state, h, FailureMode.STALL)
        h.mode = Mode.FLIGHT
        h.leg_deployed = 0
        h.hops += 1
        state.get_mutable_discrete_state().get_mutable_vector().SetFromVector(h[:])
        return EventStatus.Succeeded()
