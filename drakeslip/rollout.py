"""Rollouts: hops from an apex, aimed at footholds through the step-length controller or commanded as leg angles
open loop, on the fast step map or the Drake simulator, each giving the same record.

Every part of the toolkit that executes footsteps goes through here: the receding-horizon evaluation, plan
checking, robustness draws, the oracle's witnesses, trajectory optimization's checks and the expert's rollouts.
Noise enters where a real robot meets it: ``apex_errors`` perturb the apex the controller is told (state
estimation), ``angle_errors`` the leg angle the leg reaches (actuation), ``sensed_terrain`` is the ground the
controller believes in (perception), and the hops themselves run on the true ``terrain`` with the true ``params``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, NamedTuple, Sequence

import numpy as np

from drakeslip.params import SlipParams
from drakeslip.state import ApexState, FailureMode, check_apex, check_leg_angle
from drakeslip.stepmap import step_batch
from drakeslip.terrain import Terrain
from drakeslip.units import units_of

ROLLOUT_BACKENDS = ("fast", "drake", "multibody")
# A noisy command is clipped just short of a horizontal leg, the step map's domain; such a hop fails anyway.
ANGLE_LIMIT = math.pi / 2 - 1e-9


@dataclass
class Rollout:
    """What a rollout did: the ``footholds`` it touched down on, the ``apexes`` after each completed hop and the
    ``leg_angles`` commanded at each apex; the first ``failure`` (None if every hop completed), the hop it happened
    in (``failed_hop``, -1 without one) and the state (x, z, xdot, zdot) there (``end_state``). ``simulation`` is
    the logged Drake run when one was asked for (``log=True``)."""

    footholds: list = field(default_factory=list)
    apexes: list = field(default_factory=list)
    leg_angles: list = field(default_factory=list)
    failure: FailureMode | None = None
    failed_hop: int = -1
    end_state: tuple | None = None
    simulation: object = None

    @property
    def ok(self) -> bool:
        return self.failure is None

    @property
    def failure_x(self) -> float:
        """Where the body was when the rollout failed (NaN without a failure)."""
        return float(self.end_state[0]) if self.end_state is not None else math.nan


# many parameters: one public entry for every backend: the commands, their errors, each backend's options as keywords
def rollout(apex, terrain: Terrain, params: SlipParams | None = None, *, footholds: Sequence[float] | None = None,
            leg_angles: Sequence[float] | Callable | None = None, controller=None, backend: str = "drake",
            max_hops: int | None = None, angle_errors=None, apex_errors=None, sensed_terrain: Terrain | None = None,
            log: bool = False, integrator=None, max_time: float | None = None,
            model: SlipParams | None = None) -> Rollout:
    """Hop from ``apex`` over ``terrain`` with the hopper ``params`` until a failure or the commands run out.

    Commands, exactly one of: ``footholds``, each aimed at from the apex reached by ``controller`` (a
    ``StepLengthController``), or ``leg_angles`` commanded open loop, a list or a policy
    ``f(apex, hop) -> angle | None`` (None stops). ``max_hops`` caps the hops. ``angle_errors`` (per hop, rad) are
    added to each command; ``apex_errors`` (per hop, (x, z, xdot)) to the apex the controller or policy is told;
    ``sensed_terrain`` is what the controller aims on (default: ``terrain``). ``backend``: ``"drake"`` (the hybrid
    simulator; ``log``, ``integrator`` and ``max_time`` go to ``drakeslip.simulate``), ``"fast"``, or
    ``"multibody"`` (the multibody robot built around ``params``, ``drakeslip.multibody``: footholds only, aimed
    at by the robot's own controller, built for the hopper ``model``, default ``params``: a noise profile's model
    mismatch runs a hopper whose spring, mass and friction the controller does not know; ``log`` keeps its
    trajectory)."""
    params = params or SlipParams()
    apex = check_apex(apex, terrain, params)
    angle_errors = None if angle_errors is None else np.asarray(angle_errors, dtype=np.float64)[None]
    apex_errors = None if apex_errors is None else np.asarray(apex_errors, dtype=np.float64).reshape(1, -1, 3)
    return rollouts(np.array([apex], dtype=np.float64), terrain, params, footholds=footholds, leg_angles=leg_angles,
                    controller=controller, backend=backend, max_hops=max_hops, angle_errors=angle_errors,
                    apex_errors=apex_errors, sensed_terrain=sensed_terrain, log=log, integrator=integrator,
                    max_time=max_time, model=model)[0]


# many parameters: ``rollout``'s keyword options, each with its default, for a batch of starts
def rollouts(starts, terrain: Terrain, params: SlipParams, *, footholds=None, leg_angles=None, controller=None,
             backend: str = "fast", max_hops: int | None = None, angle_errors=None, apex_errors=None,
             sensed_terrain: Terrain | None = None, log: bool = False, integrator=None,
             max_time: float | None = None, model: SlipParams | None = None) -> list[Rollout]:
    """``rollout`` from each row of ``starts`` (n, 3), with per-draw errors ``angle_errors`` (n, hops) and
    ``apex_errors`` (n, hops, 3). On the fast backend all draws advance together, one batched step-map call per
    hop. A start that is not above the terrain fails its first hop with a TRIP (its foot starts below ground)."""
    if backend not in ROLLOUT_BACKENDS:
        raise ValueError(f"backend must be one of {ROLLOUT_BACKENDS}, got {backend!r}")
    if (footholds is None) == (leg_angles is None):
        raise ValueError("give exactly one of footholds (through the controller) or leg_angles (open loop)")
    starts = np.asarray(starts, dtype=np.float64).reshape(-1, 3)
    command = _Commands(footholds, leg_angles, controller, sensed_terrain or terrain, params, angle_errors,
                        apex_errors)
    hops = command.hops if max_hops is None else min(max_hops, command.hops or max_hops)
    if hops is not None and hops < 1:
        raise ValueError(f"a rollout needs at least one hop to command, got {hops}")
    if backend == "fast":
        return _fast(starts, terrain, params, command, hops)
    options = _SimulatorOptions(log, integrator, max_time, model)
    run = _multibody if backend == "multibody" else _drake
    return [run(i, start, terrain, params, command, hops, options) for i, start in enumerate(starts)]


class _SimulatorOptions(NamedTuple):
    """The options of ``rollouts`` for the simulator backends: keep the trajectory (``log``), Drake's
    ``integrator``, the run's ``max_time`` [s], and the hopper ``model`` the multibody robot's controller is built
    for (None: the true one)."""

    log: bool
    integrator: object
    max_time: float | None
    model: SlipParams | None


class _Commands:
    """The leg angle for draw ``i`` at ``hop`` from the apex reached, with that draw's errors."""

    def __init__(self, footholds, leg_angles, controller, sensed_terrain, params, angle_errors, apex_errors):
        self.footholds = None if footholds is None else [float(x) for x in footholds]
        self.policy = leg_angles if callable(leg_angles) else None
        self.angles = None if leg_angles is None or self.policy else [check_leg_angle(a) for a in leg_angles]
        if self.footholds is not None:
            if controller is None:
                raise ValueError("footholds are aimed at by a controller: pass controller=StepLengthController")
            controller = controller.for_params(params)   # aims with the hopper's leg length and gravity
            if not all(math.isfinite(x) for x in self.footholds):
                raise ValueError(f"footholds must be finite, got {self.footholds}")
        self.controller, self.terrain = controller, sensed_terrain
        self.angle_errors, self.apex_errors = angle_errors, apex_errors
        listed = self.footholds if self.footholds is not None else self.angles
        self.hops = None if listed is None else len(listed)

    def seen(self, draws: np.ndarray, hop: int, apexes: np.ndarray) -> np.ndarray:
        """The apexes (rows) the controller or policy is told for ``draws``."""
        if self.apex_errors is None or hop >= self.apex_errors.shape[1]:
            return apexes
        return apexes + self.apex_errors[draws, hop]

    def batch(self, draws: np.ndarray, hop: int, apexes: np.ndarray) -> np.ndarray:
        """Angles for several draws at once (NaN where a policy stops)."""
        seen = self.seen(draws, hop, apexes)
        if self.footholds is not None:
            angles = self.controller.leg_angles(seen, np.full(draws.size, self.footholds[hop]), self.terrain)
        elif self.angles is not None:
            angles = np.full(draws.size, self.angles[hop])
        else:
            angles = np.array([_nan_if_none(self.policy(ApexState(*row), hop)) for row in seen.tolist()])
        return self._with_errors(draws, hop, angles)

    def one(self, draw: int, hop: int, apex: ApexState) -> float | None:
        """The angle for one draw (None where a policy stops)."""
        seen = ApexState(*self.seen(np.array([draw]), hop, np.array([apex]))[0]) if self.apex_errors is not None \
            else apex
        if self.footholds is not None:
            angle = self.controller.leg_angle(seen, self.footholds[hop], self.terrain)
        elif self.angles is not None:
            angle = self.angles[hop]
        else:
            angle = self.policy(seen, hop)
            if angle is None:
                return None
        return float(self._with_errors(np.array([draw]), hop, np.array([float(angle)]))[0])

    def _with_errors(self, draws, hop, angles):
        if self.angle_errors is None or hop >= self.angle_errors.shape[1]:
            return angles
        return np.clip(angles + self.angle_errors[draws, hop], -ANGLE_LIMIT, ANGLE_LIMIT)


def _nan_if_none(angle) -> float:
    return math.nan if angle is None else float(angle)


def _fast(starts, terrain, params, command: _Commands, hops) -> list[Rollout]:
    records = [Rollout() for _ in range(starts.shape[0])]
    apex = starts.copy()
    below = apex[:, 1] <= terrain.height_at(apex[:, 0])
    for i in np.flatnonzero(below):
        records[i].failure, records[i].failed_hop, records[i].end_state = FailureMode.TRIP, 0, (*apex[i], 0.0)
    alive = np.flatnonzero(~below)
    hop = 0
    while alive.size and (hops is None or hop < hops):
        angles = command.batch(alive, hop, apex[alive])
        going = ~np.isnan(angles)
        alive, angles = alive[going], angles[going]
        if not alive.size:
            break
        r = step_batch(apex[alive], angles, terrain, params)
        for k, i in enumerate(alive.tolist()):
            rec = records[i]
            rec.leg_angles.append(float(angles[k]))
            if r.touchdown_x[k] == r.touchdown_x[k]:
                rec.footholds.append(float(r.touchdown_x[k]))
            if r.failure[k]:
                rec.failure, rec.failed_hop = FailureMode(int(r.failure[k])), hop
                rec.end_state = (float(r.next_x[k]), float(r.next_z[k]), float(r.next_xdot[k]), float(r.end_zdot[k]))
            else:
                rec.apexes.append(ApexState(float(r.next_x[k]), float(r.next_z[k]), float(r.next_xdot[k])))
        apex[alive] = np.column_stack([r.next_x, r.next_z, r.next_xdot])
        alive = alive[r.ok]
        hop += 1
    return records


def _multibody(draw, start, terrain, params, command: _Commands, hops, options: _SimulatorOptions) -> Rollout:
    """One draw of ``rollouts`` (its index and start) on the multibody robot."""
    from drakeslip.multibody.execute import execute
    from drakeslip.multibody.robot import RobotParams

    if command.footholds is None:
        raise ValueError("the multibody robot executes footholds (its controller aims at them), not leg angles")
    if start[1] <= terrain.height_at(start[0]):
        return Rollout(failure=FailureMode.TRIP, failed_hop=0, end_state=(*map(float, start), 0.0))
    footholds = command.footholds[:hops]
    apex_errors = None if command.apex_errors is None else command.apex_errors[draw]
    angle_errors = None if command.angle_errors is None else command.angle_errors[draw]
    known = options.model
    robot = RobotParams.for_hopper(params if known is None else known)   # built around the model's hopper
    hops = execute(start, terrain, footholds, robot.with_slip(params), sensed_terrain=command.terrain,
                   apex_errors=apex_errors, angle_errors=angle_errors, trajectory=options.log,
                   max_time=options.max_time, known=None if known is None else robot)
    failure = hops.failure
    return Rollout(list(hops.footholds), list(hops.apexes), list(hops.leg_angles),
                   None if failure is None else failure.mode, -1 if failure is None else failure.hop,
                   None if failure is None else failure.state, hops if options.log else None)


def _drake(draw, start, terrain, params, command: _Commands, hops, options: _SimulatorOptions) -> Rollout:
    """One draw of ``rollouts`` (its index and start) on the Drake simulator."""
    from drakeslip.simulation import simulate

    if start[1] <= terrain.height_at(start[0]):
        return Rollout(failure=FailureMode.TRIP, failed_hop=0, end_state=(*map(float, start), 0.0))

    def policy(apex, hop):
        return None if hops is not None and hop >= hops else command.one(draw, hop, apex)

    max_time = options.max_time
    if max_time is None and hops is not None:   # each hop ends within the per-hop limit, so n hops within n + 1
        max_time = units_of(params).hop_seconds * (hops + 1)
    sim = simulate(start, policy, terrain, params, max_hops=hops, max_time=max_time, log=options.log,
                   integrator=options.integrator)
    return Rollout(list(sim.footholds), sim.apexes, list(sim.leg_angles), sim.failure, sim.failed_hop,
                   tuple(sim.failure_event.state) if sim.failure_event is not None else None,
                   sim if options.log else None)
