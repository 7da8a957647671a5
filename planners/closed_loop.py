"""The receding-horizon loop (paper, section VII): plan on the perception window, execute the first footholds of
the plan with the controller, replan from the apex reached; repeat until the body passes the goal, a failure, no
plan, or the hop cap.

Under a noise profile (``drakeslip.noise``) the planner and the controller are told a noisy apex and see a noisy
terrain (filtered by the robot's ``map_filter``), the leg reaches a noisy angle, and the hops run on a hopper
whose stiffness, mass and friction differ from the model's; the true apex evolves on the true terrain. Every draw
comes from a generator seeded by the config's seed and the case's id, so a case gives the same result in any
process and any order.
"""
from __future__ import annotations

import zlib
from dataclasses import asdict, dataclass, field

import numpy as np

from drakeslip import ApexState, SlipParams
from drakeslip.noise import NoiseProfile
from drakeslip.rollout import ROLLOUT_BACKENDS, rollout
from drakeslip.terrain import check_window
from drakeslip.units import units_of

EXECUTED_PER_PLAN = 3   # footholds executed before replanning (the paper's protocol)
MAX_HOPS = 60           # a case that has not reached the goal after this many hops fails ("hop cap")
GOAL_SIGMAS = 5.0       # under state noise the planners aim this many standard deviations of x past the goal


@dataclass(frozen=True)
class ClosedLoopConfig:
    """``executed_per_plan`` footholds of each plan are executed before replanning; ``backend="drake"`` executes on
    the Drake hybrid simulator (the protocol), ``"fast"`` on the fast step map (quick diagnosis: is a failure the
    planner's or the model mismatch's?); ``refine`` switches the controller's Newton polish (False: the MLP alone,
    as in the paper, an ablation); ``noise`` the noise profile (its sizes the paper's hopper's, drawn in the case's
    hopper's units: ``NoiseProfile.for_hopper``) and ``seed`` the seed of its draws; ``map_filter``
    the cells of the median filter the robot runs on its sensed height map before the planner and the controller
    use it (``Terrain.denoised`` with the profile's height error; 1: the map as sensed). Without the filter a
    1 cm error per 10 cm cell makes one cell edge in six look like a step of more than 2 cm, which the planners
    keep their footholds clear of. ``robot``: on the multibody backend, the robot's ``RobotParams`` (None: the
    default robot with the case's friction), recorded with the results; ``template``: the SLIP the planners plan
    for there (None: the hopper's own parameters), e.g. the one fitted to the robot (``drakeslip.multibody.fit``),
    with the case's friction; ``pump_energy``: there, the robot raises its apex with its leg actuator where a
    plan skims the ground (``planners.drake_system.EnergyPump``; False: an ablation)."""

    executed_per_plan: int = EXECUTED_PER_PLAN
    max_hops: int = MAX_HOPS
    backend: str = "drake"
    refine: bool = True
    noise: NoiseProfile = field(default_factory=NoiseProfile)
    seed: int = 0
    map_filter: int = 1
    robot: object = None
    template: SlipParams | None = None
    pump_energy: bool = True

    def to_dict(self) -> dict:
        record = {"executed_per_plan": self.executed_per_plan, "max_hops": self.max_hops, "backend": self.backend,
                  "refine": self.refine, "noise": self.noise.to_dict(), "seed": self.seed,
                  "map_filter": self.map_filter}
        if self.backend == "multibody":
            record["robot"] = robot_record(self.robot)
            record["template"] = None if self.template is None else asdict(self.template)
            record["pump_energy"] = self.pump_energy
        return record

    def __post_init__(self):
        if self.backend not in ROLLOUT_BACKENDS:
            raise ValueError(f"backend must be one of {ROLLOUT_BACKENDS}, got {self.backend!r}")
        for name in ("executed_per_plan", "max_hops"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        check_window(self.map_filter, "map_filter")


def robot_record(robot) -> dict:
    """The multibody robot a run executes on, as its results record it: the model file and every parameter."""
    from drakeslip.multibody.robot import SDF_FILE, RobotParams

    return {"model": f"drakeslip/multibody/{SDF_FILE}", "params": (robot or RobotParams()).to_dict()}


def run_case(planner, controller, case, goal_x: float, params: SlipParams,
             config: ClosedLoopConfig = ClosedLoopConfig()) -> dict:
    """One case (``case.id``, ``case.terrain``, ``case.apex``) in the receding-horizon loop; returns
    {"id", "success", "failure", "final_x", "plans"}, one record per planning call in "plans" (with the footholds
    and leg angles executed, and the apex the planner was told in "seen_apex" under noise; "executed_params" is
    then the hopper that ran). On the ``"multibody"`` backend the case runs as one closed-loop Diagram
    (``planners.drake_system.run_closed_loop``: the planner system replans at every ``executed_per_plan``-th
    apex of the robot)."""
    if config.backend == "multibody":
        return _run_on_robot(planner, case, goal_x, params, config)
    apex, terrain = ApexState(*map(float, case.apex)), case.terrain
    noise, rng = config.noise.for_hopper(params), np.random.default_rng([config.seed, zlib.crc32(case.id.encode())])
    # a robot unsure of its x by sigma aims 5 sigma past the goal, so that believing it is past means being past
    aim_x = goal_x + GOAL_SIGMAS * noise.apex[0]
    executed = params if noise.silent else noise.executed_params(params, rng)
    plans, hops, failure = [], 0, None
    while True:
        k = config.executed_per_plan
        apex_errors = None if noise.silent else noise.apex_errors(rng, k)
        angle_errors = None if noise.silent else noise.angle_errors(rng, k)
        seen = apex if noise.silent else ApexState(*(np.asarray(apex) + apex_errors[0]))
        window = terrain.perceived(seen.x, *units_of(params).window)   # the hopper's view
        sensed = window if noise.silent else noise.perceived(window, rng, config.map_filter)
        try:
            plan = planner.plan(seen, sensed, aim_x, params)
        except ValueError as refusal:  # a noisy apex the planner cannot start from (below the ground it sees)
            if noise.silent:
                raise
            plans.append({"success": False, "message": str(refusal), "ode_calls": 0, "t_plan_s": 0.0,
                          "nodes_expanded": 0, "target_x": goal_x, "footholds": [], "apex": list(apex),
                          "seen_apex": list(seen)})
            failure, final_x = "NO_PLAN", apex.x
            break
        record = plan.summary()
        record["apex"] = list(apex)
        if not noise.silent:
            record["seen_apex"] = list(seen)
        plans.append(record)
        if not plan.success:
            failure = "NO_PLAN"
            final_x = apex.x
            break
        footholds = plan.footholds[:k].tolist()
        if not footholds:  # the robot believes it is past the goal already: it stops where it is
            failure, final_x = (None if apex.x >= goal_x else "STOPPED_SHORT"), apex.x
            break
        run = rollout(apex, terrain, executed, footholds=footholds, controller=controller, backend=config.backend,
                      apex_errors=apex_errors, angle_errors=angle_errors,
                      sensed_terrain=None if noise.silent else sensed)
        record["executed"] = [float(x) for x in run.footholds]
        record["leg_angles"] = [float(a) for a in run.leg_angles]   # as the leg reached them (with its errors)
        hops += len(footholds)
        if run.failure is not None:
            failure = run.failure.name
            final_x = run.failure_x
            break
        apex = ApexState(*map(float, run.apexes[-1]))
        final_x = apex.x
        if apex.x >= goal_x:
            break
        if hops >= config.max_hops:
            failure = "HOP_CAP"
            break
    result = {"id": case.id, "success": failure is None, "failure": failure, "final_x": final_x, "plans": plans}
    if not noise.silent:
        result["executed_params"] = asdict(executed)   # the mismatched hopper this case ran
    return result


def _run_on_robot(planner, case, goal_x: float, params: SlipParams, config: ClosedLoopConfig) -> dict:
    from planners.drake_system import run_closed_loop

    # a template fitted to the default robot (built around the paper's hopper) is its template only
    fitted_robot = params.with_friction(SlipParams().friction) == SlipParams() and config.robot is None
    template = config.template.with_friction(params.friction) if config.template and fitted_robot else params
    robot = config.robot
    if robot is None:
        from drakeslip.multibody.robot import RobotParams

        robot = RobotParams(slip=params)
    result = run_closed_loop(planner, case, goal_x, template, robot, noise=config.noise, seed=config.seed,
                             map_filter=config.map_filter, max_hops=config.max_hops,
                             replan_every=config.executed_per_plan, pump_energy=config.pump_energy)
    result["plans"] = [{k: v for k, v in plan.items() if k != "stamp"} for plan in result["plans"]]
    return result


class PlanRecorder:
    """A planner that keeps every Plan the wrapped ``planner`` returns, in the order of the loop's records (None
    where it refused the call), for what the records leave out: the plans' predicted apexes."""

    def __init__(self, planner):
        self.planner, self.plans = planner, []

    def plan(self, *args, **kwargs):
        self.plans.append(None)
        self.plans[-1] = self.planner.plan(*args, **kwargs)
        return self.plans[-1]


def executed_plans(plans, records):
    """(planned footholds, predicted apexes) of the hops that ran, as a replay draws them: the first k footholds
    and apexes of each Plan in ``plans`` (``PlanRecorder.plans``), k the number of footholds its record of
    ``records`` (a run's "plans", on either backend) says were executed."""
    executed = [(plan, len(record["executed"])) for plan, record in zip(plans, records) if "executed" in record]
    return [x for plan, k in executed for x in plan.footholds[:k]], [a for plan, k in executed for a in plan.apexes[:k]]
