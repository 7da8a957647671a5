"""A footstep planner as a Drake ``LeafSystem``, and the closed loop on the multibody hopper as one Diagram.

``FootstepPlannerSystem`` wraps any registered planner label (or planner object): at each flight apex of the
robot (the body's vertical velocity turning from up to down) it takes the state estimate (the true state plus the
noise profile's apex errors when asked), perceives the terrain window ahead of the body (with the profile's
height-map errors and the robot's map filter when asked), plans to the goal for the template ``params`` with no
foothold just before a step's face (``RobotParams.face_keep_out`` in ``build_closed_loop``), and outputs the
plan's footholds as a ``FootholdCommand`` for ``drakeslip.multibody.controller.HopperController``. Its ports:
``state`` in (the plant's state vector), ``command`` out. A user wires it into their own diagram as
``examples/hop_multibody.py`` shows; ``build_closed_loop`` and ``run_closed_loop`` do it for one case.
"""
from __future__ import annotations

import time
import zlib
from dataclasses import asdict, replace

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import LeafSystem

from drakeslip import ApexState, SlipParams
from drakeslip.multibody.controller import FootholdCommand, touchdown_angle
from drakeslip.multibody.diagram import HopperDiagram, build_diagram, set_apex_state
from drakeslip.multibody.execute import loss_prior
from drakeslip.multibody.failures import HopMonitor
from drakeslip.multibody.pump import PUMPS_WITHOUT_PLAN, EnergyPump
from drakeslip.multibody.robot import RobotParams, StateLayout
from drakeslip.noise import NoiseProfile
from drakeslip.params import check_number
from drakeslip.simulation import advance
from drakeslip.terrain import Terrain
from drakeslip.units import units_of

RISING = 0.2       # [m/s] a body rising faster than this is in flight toward an apex (not jostled by its leg)
GOAL_SIGMAS = 5.0   # under state noise the planner aims this many standard deviations of x past the goal


class FootstepPlannerSystem(LeafSystem):
    """Input ``state`` (plant state, read through ``layout``); output ``command`` (abstract FootholdCommand).

    Parameters: ``planner`` (a label for ``planners.make`` or an object with ``plan``), ``terrain`` (the world
    it perceives), ``goal_x``, ``params`` (the template it plans for), ``layout`` (the robot in the plant),
    ``time_step`` (how often it checks for an apex), ``noise`` and ``seed`` (state and perception errors drawn
    at each apex), ``map_filter`` (the robot's median filter on its sensed map), ``face_keep_out`` (how far
    before a step's face [m] it places no foothold: the planner plans on the sensed map less those footholds,
    ``Terrain.without_footholds_before_rises``; the command keeps the sensed map), ``pump`` (an ``EnergyPump``:
    when the robot raises its energy beyond the template's; None: never). Abstract state: the command and
    the number of plans made; ``records`` lists one summary per planning call of the latest run."""

    def __init__(self, planner, terrain: Terrain, goal_x: float, params: SlipParams, layout: StateLayout,
                 time_step: float = 1e-3, noise: NoiseProfile | None = None, seed: int = 0, map_filter: int = 1,
                 replan_every: int = 1, face_keep_out: float = 0.0, pump: EnergyPump | None = None):
        super().__init__()
        if isinstance(planner, str):
            import planners

            planner = planners.make(planner)
        self.planner, self.terrain, self.goal_x, self.params = planner, terrain, float(goal_x), params
        self.noise, self.map_filter, self.replan_every = noise or NoiseProfile(), map_filter, int(replan_every)
        self.face_keep_out = check_number(face_keep_out, "FootstepPlannerSystem face_keep_out")
        self.pump = pump
        self.rng = np.random.default_rng(seed)
        self._z, self._vz = layout.q[0:2], layout.v[0:2]
        self._q, self._v = list(layout.q), list(layout.v)
        self.records: list = []
        self.DeclareVectorInputPort("state", max(layout.v) + 1)
        self._command = self.DeclareAbstractState(AbstractValue.Make(FootholdCommand((), terrain, None, -1)))
        self._rising = self.DeclareDiscreteState(2)   # rising in flight (1/0); apexes since the last plan
        self.DeclarePeriodicUnrestrictedUpdateEvent(time_step, 0.0, self._update)
        self.DeclareAbstractOutputPort("command", lambda: AbstractValue.Make(FootholdCommand((), terrain, None, -1)),
                                       self._output, prerequisites_of_calc={self.all_state_ticket()})

    def _output(self, context, output):
        output.set_value(context.get_abstract_state(self._command).get_value())

    def _update(self, context, state):
        full = self.get_input_port(0).Eval(context)
        q, v = full[self._q], full[self._v]
        rising = state.get_mutable_discrete_state(self._rising).get_mutable_value()
        command = context.get_abstract_state(self._command).get_value()
        at_apex = rising[0] > 0 and v[1] <= 0.0
        rising[0] = 1.0 if v[1] > RISING else (rising[0] if v[1] > 0.0 else 0.0)
        if command.stamp >= 0:
            if not at_apex:
                return
            rising[1] += 1.0
            if rising[1] < self.replan_every and command.footholds:
                return
        rising[1] = 0.0
        apex = ApexState(float(q[0]), float(q[1]), float(v[0]))
        state.get_mutable_abstract_state(self._command).set_value(self.plan(apex, command.stamp + 1))

    def _pumps_without_plan(self) -> int:
        """Pumping hops in a row, up to now, from apexes with no plan."""
        count = 0
        for record in reversed(self.records):
            if record["success"] or "pumped" not in record:
                break
            count += 1
        return count

    def plan(self, apex: ApexState, stamp: int) -> FootholdCommand:
        """Plan from the true ``apex`` as the robot estimates and perceives it; the command numbered ``stamp``."""
        noise = self.noise
        errors = np.zeros(3) if noise.silent else noise.apex_errors(self.rng, 1)[0]
        seen = ApexState(*(np.asarray(apex) + errors))
        window = self.terrain.perceived(seen.x, *units_of(self.params).window)
        sensed = window if noise.silent else noise.perceived(window, self.rng, self.map_filter)
        aim_x = self.goal_x + GOAL_SIGMAS * noise.apex[0]
        try:
            plan = self.planner.plan(seen, sensed.without_footholds_before_rises(self.face_keep_out), aim_x,
                                     self.params)
            record = plan.summary()
        except ValueError as refusal:   # a noisy apex below the ground it sees
            record = {"success": False, "message": str(refusal), "ode_calls": 0, "t_plan_s": 0.0,
                      "nodes_expanded": 0, "target_x": self.goal_x, "footholds": []}
        record.update(apex=list(apex), stamp=stamp)
        if not noise.silent:
            record["seen_apex"] = list(seen)
        footholds = tuple(record["footholds"]) if record["success"] else ()
        g = self.params.gravity
        if self.pump is None:
            pump = False
        elif record["success"]:
            pump = self.pump.needed(plan.apexes, sensed)
        else:
            pump = self._pumps_without_plan() < PUMPS_WITHOUT_PLAN and self.pump.room(seen, sensed, g)
        # energy None: the controller keeps each apex's energy, as the template the plan was made for does
        energy = g * (seen.z + self.pump.rise) + 0.5 * seen.xdot ** 2 if pump else None
        if pump:
            record["pumped"] = self.pump.rise
        self.records.append(record)
        errors_told = (tuple(float(e) for e in errors),)
        return FootholdCommand(footholds, sensed, energy, stamp, seen.xdot if pump else 0.0, errors_told)


def build_closed_loop(planner, terrain: Terrain, goal_x: float, params: SlipParams, robot: RobotParams | None = None,
                      *, noise: NoiseProfile | None = None, seed: int = 0, map_filter: int = 1,
                      replan_every: int = 1, inject_energy: bool = True, meshcat=None,
                      known: RobotParams | None = None, pump_energy: bool = True) -> HopperDiagram:
    """Plant and scene graph (the robot, ``terrain``), the planner system (``planner`` for the template
    ``params``) and the controller (for the robot ``known``, default ``robot``), with optional Meshcat, as one
    Diagram (``HopperDiagram.diagram``). ``pump_energy``: the robot raises its energy where the template's plans
    skim (``EnergyPump``, ``PUMP_RISE``)."""
    robot = robot or RobotParams(slip=SlipParams(friction=params.friction))
    pump = EnergyPump.for_robot(known or robot, params) if pump_energy else None

    def make_planner(layout: StateLayout) -> FootstepPlannerSystem:
        system = FootstepPlannerSystem(planner, terrain, goal_x, params, layout, robot.time_step, noise, seed,
                                       map_filter, replan_every, robot.face_keep_out, pump)
        system.set_name("footstep_planner")
        return system

    return build_diagram(terrain, robot, make_planner=make_planner, inject_energy=inject_energy, meshcat=meshcat,
                         known=known)


def run_closed_loop(planner, case, goal_x: float, params: SlipParams, robot: RobotParams | None = None, *,
                    noise: NoiseProfile | None = None, seed: int = 0, map_filter: int = 1, max_hops: int = 60,
                    replan_every: int = 1, inject_energy: bool = True, trajectory: bool = False,
                    meshcat=None, pump_energy: bool = True) -> dict:
    """One case (``case.id``, ``case.terrain``, ``case.apex``) in the closed-loop Diagram, replanning at every
    apex, until the body passes ``goal_x`` at an apex, a failure, no plan, or ``max_hops``. Returns {"id",
    "success", "failure", "what", "final_x", "plans", "hops", "max_pitch", "simulated_s", "wall_s"} (and "log",
    the HopLog, with ``trajectory``); each record of "plans" that found a plan lists in "executed" the footholds
    the robot touched down on aiming at its footholds, as the SLIP's loop records them. Noise draws come from
    ``seed`` and the case's id; under a model mismatch the plant is the drawn robot ("executed_params") and the
    controller keeps ``robot``'s values, as the SLIP's controller keeps the model's."""
    noise = noise or NoiseProfile()
    rng_seed = [seed, zlib.crc32(case.id.encode())]
    model = robot or RobotParams(slip=SlipParams(friction=params.friction))
    robot = model
    if not noise.silent:   # the case's model mismatch: the robot's spring, mass and friction drawn once
        robot = replace(model, slip=noise.executed_params(model.slip, np.random.default_rng(rng_seed)))
    hd = build_closed_loop(planner, case.terrain, goal_x, params, robot, noise=noise,
                           seed=np.random.SeedSequence(rng_seed).generate_state(1)[0], map_filter=map_filter,
                           replan_every=replan_every, inject_energy=inject_energy, meshcat=meshcat, known=model,
                           pump_energy=pump_energy)
    simulator = Simulator(hd.diagram)
    context = simulator.get_mutable_context()
    apex = ApexState(*map(float, case.apex))
    # the first plan is made before the start, so that the leg starts aimed at its first foothold
    first = hd.planner.plan(apex, 0)
    hd.planner.GetMyMutableContextFromRoot(context).SetAbstractState(0, first)
    angle = hd.controller.raibert_angle(apex.xdot, first.speed) if not first.footholds else touchdown_angle(
        apex.x, apex.z, apex.xdot, 0.0, first.footholds[0], first.terrain.height_at(first.footholds[0]),
        robot.rest_extension, robot.foot_radius, robot.slip.gravity)
    set_apex_state(hd, context, apex, angle, loss_prior(apex.xdot))
    monitor = _GoalMonitor(hd, case.terrain, context, max_hops, goal_x, trajectory)
    simulator.set_monitor(monitor)
    if hd.visualizer is not None:
        hd.visualizer.StartRecording()
    start = time.perf_counter()
    advance(simulator, monitor.hop_seconds * (max_hops + 1), lambda: f"the robot's hop {len(monitor.log.footholds)}")
    wall = time.perf_counter() - start
    if hd.visualizer is not None:
        hd.visualizer.StopRecording()
        hd.visualizer.PublishRecording()
    log, records = monitor.log, hd.planner.records
    _record_executed(records, log)
    failure = None if log.failure is None else log.failure.mode.name
    final_x = log.apexes[-1].x if log.apexes else apex.x
    if failure is None and monitor.outcome != "goal":
        failure = monitor.outcome
    result = {"id": case.id, "success": failure is None, "failure": failure,
              "what": log.failure.what if log.failure else monitor.outcome,
              "final_x": float(log.failure.x if log.failure else final_x), "plans": records,
              "hops": len(log.footholds), "max_pitch": log.max_pitch, "simulated_s": context.get_time(),
              "wall_s": wall}
    if not noise.silent:
        result["executed_params"] = asdict(robot.slip)
    if trajectory:
        result["log"] = log
    return result


def _record_executed(records: list, log) -> None:
    """Give each record that found a plan the touchdowns (foot x) that aimed at its footholds, in order: the
    first k of its footholds were executed, where k is their number."""
    commanded = {}
    for record in records:
        if record["success"]:
            record["executed"] = []
            commanded[record["stamp"]] = record
    for x, (stamp, index) in zip(log.footholds, log.aimed):
        record = commanded.get(stamp)
        if record is not None and index < len(record["footholds"]):
            record["executed"].append(float(x))


class _GoalMonitor(HopMonitor):
    """HopMonitor that ends the run at the first apex past the goal (outcome "goal"), when the planner found no
    plan and the robot does not pump instead ("NO_PLAN"), or at the hop cap ("HOP_CAP")."""

    def __init__(self, hd, terrain, context, max_hops, goal_x, trajectory):
        super().__init__(hd, terrain, context, None, trajectory)
        self.max_hops, self.goal_x, self.outcome = max_hops, goal_x, "running"
        self.planner_context = hd.planner.GetMyContextFromRoot(context)

    def __call__(self, root_context):
        status = super().__call__(root_context)
        if self.log.failure is not None:
            self.outcome = "failure"
            return status
        command = self.planner_context.get_abstract_state(0).get_value()
        self.command_footholds = command.footholds
        apexes = self.log.apexes
        if apexes and apexes[-1].x >= self.goal_x:
            self.outcome = "goal"
        elif self.hd.planner.records and not self.hd.planner.records[-1]["success"] \
                and "pumped" not in self.hd.planner.records[-1]:
            self.outcome = "NO_PLAN"
        elif len(self.log.footholds) >= self.max_hops:
            self.outcome = "HOP_CAP"
        else:
            return status
        from pydrake.systems.framework import EventStatus

        return EventStatus.ReachedTermination(self.hd.diagram, self.outcome)
