"""Multi-hop simulation of the SlipHopper in Drake's Simulator, and the Drake backend of the step map."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np
from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator
from pydrake.systems.framework import DiagramBuilder, EventStatus
from pydrake.systems.primitives import LogVectorOutput

from drakeslip.hybrid_hopper import ApexPolicy, HybridEvent, HybridHopper, Mode
from drakeslip.slip_hopper import SlipHopper
from drakeslip.params import SlipParams
from drakeslip.state import ApexState, FailureMode, SimulationCrash, StepResult, check_apex
from drakeslip.terrain import Terrain
from drakeslip.units import HOP_SECONDS, RUN_SECONDS, units_of


@dataclass(frozen=True)
class IntegratorConfig:
    """Drake integrator settings. ``scheme`` is any name accepted by ResetIntegratorFromFlags
    (error-controlled: runge_kutta3, runge_kutta5, bogacki_shampine3, radau3, ...)."""

    scheme: str = "runge_kutta5"
    accuracy: float = 1e-8
    # Guards are only checked at step ends, so an event undone within one step is missed: a foot that touches
    # down within one step's travel of a ditch edge, or a stance shorter than a step. 2 ms (about the fast
    # backend's RK4 stance step) keeps that window to a few mm for ~10 % more time than 5 ms.
    max_step: float = 2e-3

    def __post_init__(self):
        if not (self.accuracy > 0 and self.max_step > 0):
            raise ValueError(f"IntegratorConfig needs positive accuracy and max_step, got {self}")


@dataclass
class SimulationResult:
    """A logged multi-hop trajectory.

    ``times`` (N,) and ``states`` (N, 4) are the body trajectory (x, z, xdot, zdot) at every integrator step;
    ``hybrid`` (N, 7) is the HybridState alongside; ``events`` the HybridEvent log; ``failure`` the first
    failure (None if the run ended by running out of commands or hops); ``failure_event`` its log entry.
    """

    times: np.ndarray
    states: np.ndarray
    hybrid: np.ndarray
    events: tuple
    failure: FailureMode | None
    failure_event: HybridEvent | None
    integrator_steps: int
    params: SlipParams
    terrain: Terrain
    leg_angles: list = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.failure is None

    @property
    def apexes(self) -> list[ApexState]:
        """Every apex reached after the start (the start apex is not included)."""
        return [ApexState(*e.state[:3]) for e in self.events if e.kind == "apex"]

    @property
    def footholds(self) -> list[float]:
        return [e.foot[0] for e in self.events if e.kind == "touchdown"]

    @property
    def failed_hop(self) -> int:
        """The hop (0 = the one from the start apex) in which the run failed, -1 without a failure. The start apex
        is not in the event log, so the logged apexes up to the failure (a TRIP is logged at its own apex) count
        the hops begun before it."""
        if self.failure_event is None:
            return -1
        return sum(1 for e in self.events if e.kind == "apex" and e.time <= self.failure_event.time)


def policy_from(leg_angles, as_command: Callable = float) -> Callable:
    """``leg_angles`` if it is a policy, else the policy that gives the commands of the list (``as_command`` of each)
    one per hop, then None."""
    if callable(leg_angles):
        return leg_angles
    angles = [as_command(a) for a in leg_angles]
    return lambda apex, hop: angles[hop] if hop < len(angles) else None


# many parameters: the options of a public entry point (limits, integrator, log, added systems), each with a default
def simulate(apex, leg_angles: Sequence[float] | Callable, terrain: Terrain | None = None,
             params: SlipParams | None = None, max_hops: int | None = None, max_time: float | None = None,
             max_hop_time: float | None = None, integrator: IntegratorConfig | None = None,
             log: bool = True, add_to: Callable | None = None) -> SimulationResult:
    """Simulate hops from ``apex`` in Drake until the first failure, the commands run out, ``max_hops``
    apexes are reached, or ``max_time`` [s] (default ``RUN_SECONDS`` in the hopper's time units,
    ``drakeslip.units``). ``leg_angles`` is a list (one per hop) or a callback
    ``f(apex: ApexState, hop_index) -> angle | None``, called at each apex. A hop that takes longer than
    ``max_hop_time`` [s] (default ``HOP_SECONDS`` in the hopper's time units) ends the run as a TIMEOUT. When the
    integrator raises, or the derivatives are not finite (NaN), the run stops at once with ``SimulationCrash``
    naming the time, the hop's mode and the state.

    ``add_to`` adds your own systems to the diagram: ``add_to(builder, hopper)`` is called with the
    DiagramBuilder and the SlipHopper once the hopper and its apex policy are added and connected, before
    ``Build()``; connect to the hopper's output ports ``"state"`` (x, z, xdot, zdot) and ``"hybrid"``
    (HybridState) - its one input port is already taken by the policy. If it returns a callable, that is called
    with the Simulator once the run has ended, e.g. to read a log: ``sink.FindLog(simulator.get_context())``.
    Systems that only publish on every step (loggers, a visualizer publishing per step) leave the run as it is;
    a periodic publish or update event makes the integrator stop at its times too, and added continuous state
    is integrated (and error-controlled) with the hopper's: either moves the integrator's steps, and so the
    result within the integrator's accuracy."""
    params = params or SlipParams()
    terrain = terrain or Terrain.flat()
    apex = check_apex(apex, terrain, params)
    units = units_of(params)
    max_time, max_hop_time = units.time_or(max_time, RUN_SECONDS), units.time_or(max_hop_time, HOP_SECONDS)
    integrator = integrator or IntegratorConfig()
    if max_hops is not None and max_hops < 1:
        raise ValueError(f"max_hops must be at least 1, got {max_hops}")
    used_angles: list[float] = []
    policy = counted_policy(policy_from(leg_angles), max_hops, used_angles, float)
    hopper = SlipHopper(params, terrain)
    run = run_hopper(hopper, lambda context: hopper.set_apex(context, apex), policy, max_time, max_hop_time,
                     integrator, log, add_to)
    times, states, hybrid, events, failure_event, steps = run
    return SimulationResult(times=times, states=states, hybrid=hybrid, events=events,
                            failure=failure_event.failure if failure_event else None, failure_event=failure_event,
                            integrator_steps=steps,
                            params=params, terrain=terrain, leg_angles=used_angles)


def counted_policy(user_policy: Callable, max_hops: int | None, used: list, as_command: Callable) -> Callable:
    """``user_policy`` stopped after ``max_hops`` hops, appending each hop's command (``as_command`` of it) to
    ``used`` once."""
    def policy(a, hop):
        if max_hops is not None and hop >= max_hops:
            return None
        command = user_policy(a, hop)
        if command is not None and len(used) == hop:
            used.append(as_command(command))
        return command

    return policy


# many parameters: simulate's options, passed on
def run_hopper(hopper: HybridHopper, start: Callable, policy: Callable, max_time: float, max_hop_time: float,
               integrator: IntegratorConfig, log: bool, add_to: Callable | None) -> tuple:
    """Simulate ``hopper`` (a SlipHopper or SlipHopper3D), put at its start by ``start(hopper_context)`` and commanded
    by ``policy``, as ``simulate`` says: (times, body states, hybrid states, the event log, its first failure event or
    None, integrator steps)."""
    diagram, logs, when_done = hopper_diagram(hopper, policy, log, add_to)
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    hopper_context = hopper.GetMyMutableContextFromRoot(context)
    start(hopper_context)
    ResetIntegratorFromFlags(simulator, integrator.scheme, integrator.max_step)
    context.SetAccuracy(integrator.accuracy)
    timed_out = [False]
    simulator.set_monitor(hop_monitor(hopper, max_hop_time, timed_out))
    advance(simulator, max_time, lambda: f"{Mode(int(hopper.hybrid(hopper_context).mode)).name}, state "
                                         f"({', '.join(f'{v:g}' for v in hopper.body(hopper_context)[:])})")
    if callable(when_done):
        when_done(simulator)
    events, failure_event = failure_of(hopper, hopper_context, context.get_time(), timed_out[0])
    if logs is not None:
        slog, hlog = logs[0].FindLog(context), logs[1].FindLog(context)
        times, states, hybrid = slog.sample_times(), slog.data().T.copy(), hlog.data().T.copy()
    else:
        times = np.zeros(0)
        states, hybrid = np.zeros((0, len(hopper.BODY._fields))), np.zeros((0, len(hopper.HYBRID._fields)))
    return times, states, hybrid, events, failure_event, simulator.get_integrator().get_num_steps_taken()


def hopper_diagram(hopper: HybridHopper, policy: Callable, log: bool, add_to: Callable | None):
    """(diagram, (state logger, hybrid logger) or None, what ``add_to`` returned): ``hopper`` driven by ``policy``,
    its outputs logged when ``log``, and the caller's systems."""
    builder = DiagramBuilder()
    builder.AddSystem(hopper)
    controller = builder.AddSystem(ApexPolicy(policy, hopper))
    builder.Connect(hopper.GetOutputPort("state"), controller.get_input_port(0))
    builder.Connect(hopper.GetOutputPort("hybrid"), controller.get_input_port(1))
    builder.Connect(controller.get_output_port(0), hopper.get_input_port(0))
    logs = (LogVectorOutput(hopper.GetOutputPort("state"), builder),
            LogVectorOutput(hopper.GetOutputPort("hybrid"), builder)) if log else None
    when_done = add_to(builder, hopper) if add_to is not None else None
    return builder.Build(), logs, when_done


def hop_monitor(hopper: HybridHopper, max_hop_time: float, timed_out: list) -> Callable:
    """The simulator's monitor: ends the run when the hopper fails or halts, or (setting ``timed_out[0]``) when a
    hop has lasted more than ``max_hop_time`` [s] since the last liftoff."""
    last_liftoff = [0.0, 0]

    def monitor(root_context):
        c = hopper.GetMyContextFromRoot(root_context)
        h = hopper.hybrid(c)
        if h.mode in (Mode.FAILED, Mode.HALTED):
            return EventStatus.ReachedTermination(hopper, Mode(int(h.mode)).name)
        if h.hops != last_liftoff[1]:
            last_liftoff[:] = [root_context.get_time(), h.hops]
        if root_context.get_time() - last_liftoff[0] > max_hop_time:
            timed_out[0] = True
            return EventStatus.ReachedTermination(hopper, "hop time-out")
        return EventStatus.DidNothing()

    return monitor


def failure_of(hopper: HybridHopper, hopper_context, time: float, timed_out: bool) -> tuple:
    """(the event log, its first failure event or None): a run the monitor timed out at ``time`` without a failure
    gets a TIMEOUT event, appended to the log."""
    events = hopper.event_log(hopper_context)
    failure_event = next((e for e in events if e.kind == "failure"), None)
    if failure_event is None and timed_out:
        h, s = hopper.hybrid(hopper_context), hopper.body(hopper_context)
        failure_event = HybridEvent("failure", time, tuple(float(v) for v in s[:]), None, hopper.leg_command(h),
                                    FailureMode.TIMEOUT)
        events = events + (failure_event,)
    return events, failure_event


def advance(simulator, end: float, where: Callable[[], str], initialize: bool = True) -> None:
    """Initialize ``simulator`` (unless it goes on from where an earlier call stopped it: ``initialize`` False) and
    advance it to ``end``; when its integrator (or a callback it calls) raises, a ``SimulationCrash`` in one line naming
    the time, ``where()`` (the system's mode and state) and the cause."""
    try:
        if initialize:
            simulator.Initialize()
        simulator.AdvanceTo(end)
    except SimulationCrash:
        raise
    except (RuntimeError, ArithmeticError) as error:
        cause = (str(error).strip().splitlines() or [type(error).__name__])[0]
        raise SimulationCrash(f"the integrator failed at t={simulator.get_context().get_time():.6g} s in "
                              f"{where()}: {cause}") from error


def drake_step(apex: ApexState, leg_angle: float, terrain: Terrain, params: SlipParams,
               integrator: IntegratorConfig | None = None) -> StepResult:
    """The step map f(a, t, theta) on the Drake hybrid simulator: one commanded hop, then halt at the apex."""
    sim = simulate(apex, [leg_angle], terrain, params, integrator=integrator, log=False)
    touchdown = next((e for e in sim.events if e.kind == "touchdown"), None)
    touchdown_x = touchdown.foot[0] if touchdown else math.nan
    if sim.failure is not None:
        e = sim.failure_event
        return StepResult(ok=False, failure=sim.failure, touchdown_x=touchdown_x, next_apex=None, time=e.time,
                          end_state=e.state, work=sim.integrator_steps)
    apex_event = next((e for e in sim.events if e.kind == "apex"), None)
    if apex_event is None:  # simulate() stops at a failure (a time-out among them) or a halt at an apex
        raise RuntimeError("Drake simulation ended without an apex or a failure")
    return StepResult(ok=True, failure=None, touchdown_x=touchdown_x, next_apex=ApexState(*apex_event.state[:3]),
                      time=apex_event.time, end_state=apex_event.state, work=sim.integrator_steps)
