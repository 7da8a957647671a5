"""The receding-horizon loop on the multibody robot: a footstep planner as a Drake ``LeafSystem``, and one case as
one closed-loop Diagram (plant, planner system, controller).

``FootstepPlannerSystem`` makes the loop's planning call (``planners.replanning.Replanner``: the apex told, the map
sensed, the goal aimed at) at the robot's flight apexes (the body's vertical velocity turning from up to down), at
every ``replan_every``-th one, and outputs the plan's footholds as a ``FootholdCommand`` for
``drakeslip.multibody.controller.HopperController``, with the energy the robot pumps where the template cannot
(``drakeslip.multibody.pump.EnergyPump``). A user wires it into their own diagram as ``examples/hop_multibody.py``
shows; ``build_closed_loop`` and ``run_closed_loop`` do it for one case, as ``planners.closed_loop.run_case`` does on
its ``"multibody"`` backend.
"""
from __future__ import annotations

import copy
import time
from dataclasses import asdict, dataclass, replace

import numpy as np
from pydrake.common.containers import namedview
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import EventStatus, LeafSystem

from drakeslip import ApexState, SlipParams
from drakeslip.multibody.controller import FootholdCommand, HeldLeg, touchdown_angle
from drakeslip.multibody.diagram import HopperDiagram, build_diagram, set_apex_state
from drakeslip.multibody.execute import loss_prior
from drakeslip.multibody.failures import HopMonitor
from drakeslip.multibody.pump import EnergyPump
from drakeslip.multibody.robot import RobotParams, StateLayout
from drakeslip.simulation import advance
from planners.replanning import (ClosedLoopConfig, Replanner, case_result, case_seed, drawn_hopper,
                                 flown_footholds)

RISING = 0.2       # [m/s] a body rising faster than this is in flight toward an apex (not jostled by its leg)
# The robot's loop as ``run_closed_loop`` runs it unless told otherwise: noiseless, replanning at every apex.
REPLAN_AT_EVERY_APEX = ClosedLoopConfig(backend="multibody", executed_per_plan=1)

# The planner system's discrete state: whether the body is rising in flight (1/0), apexes since the last plan.
ApexWatch = namedview("ApexWatch", ["rising", "apexes_since_plan"])


@dataclass(frozen=True)
class PlanningLog:
    """What the planner system has done, kept in its Context: ``rng``, the generator of the next planning call's
    noise draws, and ``records``, one record per planning call so far. Never changed in place (a planning call
    draws from a copy of ``rng`` and makes a new log), so the copies of a Context that Drake makes may share it."""

    rng: np.random.Generator
    records: tuple = ()

    def __deepcopy__(self, memo):
        return self

    def pumps_without_plan(self) -> int:
        """Pumping hops in a row, up to now, from apexes with no plan."""
        count = 0
        for record in reversed(self.records):
            if record["success"] or "pumped" not in record:
                break
            count += 1
        return count


class ApexPlannerSystem(LeafSystem):
    """A footstep planner that plans at a robot's flight apexes, in two or three dimensions: each period it reads the
    body's vertical velocity from the plant's state, marks an apex where a body that rose faster than RISING stops
    rising, and there, at every ``replan_every``-th apex or when the command holds no footholds, makes the planning
    call ``plan_at`` (a subclass's) and outputs its command.

    Input port
      state: the plant's state vector.
    Output port
      command: abstract (``no_command`` before the first plan; each plan's stamp is the last's + 1).
    State
      discrete (``ApexWatch``): rising, apexes_since_plan.
      abstract: the command; the planning log (``log``, a value the subclass defines, never changed in place).
    Parameters
      ``state_size``, ``vertical_rate`` (the index of the body's vertical velocity in the state), ``time_step`` (how
      often it checks for an apex), ``replan_every``, ``no_command`` and ``log`` (the first values). Everything that
      changes lives in the Context, so one system can be simulated in many contexts.
    """

    def __init__(self, state_size: int, vertical_rate: int, no_command, log, *, time_step: float = 1e-3,
                 replan_every: int = 1):
        super().__init__()
        self.replan_every, self._vertical_rate = int(replan_every), int(vertical_rate)
        self.DeclareVectorInputPort("state", state_size)
        self._command = self.DeclareAbstractState(AbstractValue.Make(no_command))
        self._log = self.DeclareAbstractState(AbstractValue.Make(log))
        self._watch = self.DeclareDiscreteState(len(ApexWatch.get_fields()))
        self.DeclarePeriodicUnrestrictedUpdateEvent(time_step, 0.0, self._update)
        self.DeclareAbstractOutputPort("command", lambda: AbstractValue.Make(no_command), self._output,
                                       prerequisites_of_calc={self.all_state_ticket()})

    def plan_at(self, state: np.ndarray, stamp: int, log) -> tuple:
        """(the command numbered ``stamp``, the log after it): the planning call at the apex the plant's ``state``
        vector is at."""
        raise NotImplementedError

    def command(self, context):
        """The command in the system's ``context``."""
        return context.get_abstract_state(self._command).get_value()

    def log(self, context):
        """The planning log in the system's ``context``."""
        return context.get_abstract_state(self._log).get_value()

    def start_at(self, context, state: np.ndarray):
        """Plan at the plant's ``state`` before a run starts there (the command numbered 0) into the system's
        ``context``, so that the leg starts aimed at the first foothold; returns the command."""
        return self.begin(context, *self.plan_at(state, 0, self.log(context)))

    def begin(self, context, command, log):
        """Set the first ``command`` and the ``log`` after it in the system's ``context``; returns the command."""
        context.SetAbstractState(self._command, command)
        context.SetAbstractState(self._log, log)
        return command

    def _output(self, context, output):
        output.set_value(self.command(context))

    def _update(self, context, state):
        full = self.get_input_port(0).Eval(context)
        rate = full[self._vertical_rate]
        watch = ApexWatch(state.get_mutable_discrete_state(self._watch).get_mutable_value())
        command = self.command(context)
        at_apex = watch.rising > 0 and rate <= 0.0
        watch.rising = 1.0 if rate > RISING else (watch.rising if rate > 0.0 else 0.0)
        if command.stamp >= 0:
            if not at_apex:
                return
            watch.apexes_since_plan += 1.0
            if watch.apexes_since_plan < self.replan_every and command.footholds:
                return
        watch.apexes_since_plan = 0.0
        command, log = self.plan_at(full, command.stamp + 1, self.log(context))
        state.get_mutable_abstract_state(self._command).set_value(command)
        state.get_mutable_abstract_state(self._log).set_value(log)


class FootstepPlannerSystem(ApexPlannerSystem):
    """The loop's planner at the planar robot's apexes (see the module doc), an ``ApexPlannerSystem`` whose command
    is a ``FootholdCommand`` and whose log is a ``PlanningLog``.

    Input port
      state: the plant's state vector, read through ``layout``.
    Output port
      command: abstract ``FootholdCommand`` (stamp -1 before the first plan; each plan's stamp is the last's + 1).
    State
      discrete (``ApexWatch``): rising, apexes_since_plan.
      abstract: the command; the ``PlanningLog`` (the noise generator, seeded by ``seed``, and the records).
    Parameters
      ``replanner`` (the planner, the world, the goal, the template, the noise profile, the map filter and the face
      keep-out: ``planners.replanning.Replanner``), ``layout`` (the robot in the plant), ``time_step`` (how often
      it checks for an apex), ``seed``, ``replan_every`` (plan at every k-th apex, and at any apex past the last
      foothold), ``pump`` (an ``EnergyPump``: when the robot raises its energy beyond the template's; None:
      never). Everything that changes lives in the Context, so one system can be simulated in many contexts.
    """

    def __init__(self, replanner: Replanner, layout: StateLayout, *, time_step: float = 1e-3, seed: int = 0,
                 replan_every: int = 1, pump: EnergyPump | None = None):
        self.replanner, self.pump = replanner, pump
        self._q, self._v = list(layout.q), list(layout.v)
        super().__init__(max(layout.v) + 1, layout.v[1], FootholdCommand((), replanner.terrain, None, -1),
                         PlanningLog(np.random.default_rng(seed)), time_step=time_step, replan_every=replan_every)

    def records(self, context) -> tuple:
        """One record per planning call made in the system's ``context``."""
        return self.log(context).records

    def start(self, context, apex: ApexState) -> FootholdCommand:
        """Plan from ``apex`` before a run starts there (the command numbered 0) into the system's ``context``,
        so that the leg starts aimed at the first foothold; returns the command."""
        return self.begin(context, *self._plan(apex, 0, self.log(context)))

    def last_hop(self, records) -> tuple | None:
        """The hop that reached this apex, as the last planning call saw it start, (x, z, xdot, foothold x): the
        first foothold it had the robot fly, when the robot plans at every apex (None: not known)."""
        if not records or self.replan_every != 1:
            return None
        last = records[-1]
        flown = () if last.get("in_place") else flown_footholds(last)
        return (*last.get("seen_apex", last["apex"]), flown[0]) if flown else None

    def plan_at(self, state: np.ndarray, stamp: int, log: PlanningLog) -> tuple:
        q, v = state[self._q], state[self._v]
        return self._plan(ApexState(float(q[0]), float(q[1]), float(v[0])), stamp, log)

    def _plan(self, apex: ApexState, stamp: int, log: PlanningLog) -> tuple:
        """(the command numbered ``stamp``, the log after it): plan from the true ``apex`` as the robot estimates
        and perceives it, its noise drawn from a copy of ``log``'s generator (the apex's error, then the map's)."""
        noise, params = self.replanner.noise, self.replanner.params
        rng = copy.deepcopy(log.rng)
        error = None if noise.silent else noise.apex_errors(rng, 1)[0]
        call = self.replanner.plan(apex, error, rng, self.last_hop(log.records))
        record, seen = call.record, call.seen
        record["stamp"] = stamp
        success = record["success"]
        pumps, gravity = log.pumps_without_plan(), params.gravity
        # with no plan the robot hops in place, raising its energy, where the ground has room for it: that commits it
        # to nothing, where a safe hop (the plan's ``safe_footholds``, flown otherwise) takes it on toward the obstacle
        in_place = not success and self.pump is not None and self.pump.wanted(None, seen, call.sensed, gravity, pumps)
        flown = () if in_place else flown_footholds(record)
        pump = in_place or self.pump is not None and self.pump.wanted(call.plan.apexes if success else None, seen,
                                                                      call.sensed, gravity, pumps, bool(flown))
        # energy None: the controller keeps each apex's energy, as the template the plan was made for does
        energy = self.pump.energy(seen, params.gravity) if pump else None
        if pump:
            record["pumped"] = self.pump.rise
        if in_place:
            record["in_place"] = True
        errors_told = (tuple(float(e) for e in (np.zeros(3) if error is None else error)),)
        command = FootholdCommand(tuple(flown), call.sensed, energy, stamp,
                                  seen.xdot if pump else 0.0, errors_told)
        return command, PlanningLog(rng, log.records + (record,))


def build_closed_loop(replanner: Replanner, robot: RobotParams | None = None, *, known: RobotParams | None = None,
                      seed: int = 0, replan_every: int = 1, pump_energy: bool = True, inject_energy: bool = True,
                      meshcat=None) -> HopperDiagram:
    """Plant and scene graph (the robot, ``replanner.terrain``), the planner system (``replanner`` with the robot's
    ``face_keep_out``; ``seed`` and ``replan_every`` as there) and the controller (for the robot ``known``, default
    ``robot``: a noise profile's model mismatch runs another plant), with optional Meshcat, as one Diagram
    (``HopperDiagram.diagram``). ``robot`` defaults to the paper's with the template's friction; ``pump_energy``:
    the robot raises its energy where the template's plans skim (``EnergyPump``)."""
    robot = robot or RobotParams(slip=SlipParams(friction=replanner.params.friction))
    pump = EnergyPump.for_robot(known or robot, replanner.params) if pump_energy else None
    replanner = replace(replanner, face_keep_out=robot.face_keep_out)

    def make_planner(layout: StateLayout) -> FootstepPlannerSystem:
        system = FootstepPlannerSystem(replanner, layout, time_step=robot.time_step, seed=seed,
                                       replan_every=replan_every, pump=pump)
        system.set_name("footstep_planner")
        return system

    return build_diagram(replanner.terrain, robot, make_planner=make_planner, inject_energy=inject_energy,
                         meshcat=meshcat, known=known)


def run_closed_loop(planner, case, goal_x: float, params: SlipParams,
                    config: ClosedLoopConfig = REPLAN_AT_EVERY_APEX, *, inject_energy: bool = True,
                    trajectory: bool = False, meshcat=None) -> dict:
    """One case (``case.id``, ``case.terrain``, ``case.apex``) on the robot ``config.robot`` (None: the paper's
    with the friction of ``params``, the template the planner plans for), replanning at every
    ``config.executed_per_plan``-th apex, until the body passes ``goal_x`` at an apex, a failure, no plan, or
    ``config.max_hops``. Returns the loop's ``case_result`` with the robot's "what", "hops", "max_pitch",
    "simulated_s" and "wall_s" (and "log", the HopLog, with ``trajectory``); each record of "plans" that found a
    plan lists in "executed" the footholds the robot touched down on aiming at its footholds. Noise draws come
    from ``config.seed`` and the case's id: the model mismatch first (the plant is the drawn robot,
    "executed_params", while the controller keeps the model's values, as the SLIP's controller does), then the
    planner system's, from a generator of its own."""
    noise, seed = config.noise, case_seed(config.seed, case.id)
    model = config.robot or RobotParams(slip=SlipParams(friction=params.friction))
    robot = replace(model, slip=drawn_hopper(noise, model.slip, np.random.default_rng(seed)))
    replanner = Replanner(planner, case.terrain, goal_x, params, noise, config.map_filter)
    hd = build_closed_loop(replanner, robot, known=model, seed=np.random.SeedSequence(seed).generate_state(1)[0],
                           replan_every=config.executed_per_plan, pump_energy=config.pump_energy,
                           inject_energy=inject_energy, meshcat=meshcat)
    result = simulate_closed_loop(hd, case, goal_x, config.max_hops, trajectory)
    if not noise.silent:
        result["executed_params"] = asdict(robot.slip)
    return result


def simulate_closed_loop(hd: HopperDiagram, case, goal_x: float, max_hops: int, trajectory: bool = False) -> dict:
    """Run the closed-loop Diagram ``hd`` (``build_closed_loop``) from a fresh Context at the apex ``case.apex``
    over ``case.terrain``; returns ``run_closed_loop``'s result, but for "executed_params"."""
    simulator = Simulator(hd.diagram)
    context = simulator.get_mutable_context()
    apex = ApexState(*map(float, case.apex))
    robot = hd.params
    # the first plan is made before the start, so that the leg starts aimed at its first foothold
    first = hd.planner.start(hd.planner.GetMyMutableContextFromRoot(context), apex)
    angle = hd.controller.raibert_angle(apex.xdot, first.speed) if not first.footholds else touchdown_angle(
        apex.x, apex.z, apex.xdot, 0.0, first.footholds[0], first.terrain.height_at(first.footholds[0]),
        HeldLeg(robot.rest_extension, robot.foot_radius, robot.slip.gravity))
    set_apex_state(hd, context, apex, angle, loss_prior(apex.xdot, robot.slip))
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
    log = monitor.log
    records = executed_records(hd.planner.records(monitor.planner_context), log)
    failure = None if log.failure is None else log.failure.mode.name
    final_x = log.apexes[-1].x if log.apexes else apex.x
    if failure is None and monitor.outcome != "goal":
        failure = monitor.outcome
    result = case_result(case.id, failure, float(log.failure.x if log.failure else final_x), records)
    result.update(what=log.failure.what if log.failure else monitor.outcome, hops=len(log.footholds),
                  max_pitch=log.max_pitch, simulated_s=context.get_time(), wall_s=wall)
    if trajectory:
        result["log"] = log
    return result


def executed_records(records, log) -> list:
    """Copies of the planner system's ``records``, each that found a plan given the touchdowns (foot x) of
    ``log`` that aimed at its footholds, in order, as "executed": the first k of its footholds were executed,
    where k is their number."""
    records = [dict(record) for record in records]
    commanded = {}
    for record in records:
        if record["success"] or "safe_footholds" in record:
            record["executed"] = []
            commanded[record["stamp"]] = record
    for x, (stamp, index) in zip(log.footholds, log.aimed):
        record = commanded.get(stamp)
        if record is not None and index < len(flown_footholds(record)):
            record["executed"].append(float(x))
    return records


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
        self.command_footholds = self.hd.planner.command(self.planner_context).footholds
        records = self.hd.planner.records(self.planner_context)
        apexes = self.log.apexes
        if apexes and apexes[-1].x >= self.goal_x:
            self.outcome = "goal"
        elif records and not (records[-1]["success"] or "safe_footholds" in records[-1]
                              or "pumped" in records[-1]):
            self.outcome = "NO_PLAN"
        elif len(self.log.footholds) >= self.max_hops:
            self.outcome = "HOP_CAP"
        else:
            return status
        return EventStatus.ReachedTermination(self.hd.diagram, self.outcome)
