"""The receding-horizon loop (paper, section VII): plan on the perception window, execute the first footholds of
the plan, replan from the apex reached; repeat until the body passes the goal, a failure, no plan, or the hop cap.
One loop on two backends (``run_case``): the template's, its hops rolled out by the controller on the Drake hybrid
simulator or the fast step map (here), and the multibody robot's, one closed-loop Drake Diagram whose planner system
replans at the robot's apexes (``planners.drake_system``). Both plan through ``planners.replanning.Replanner`` and
record their cases with ``case_result``.

Under a noise profile (``drakeslip.noise``) the planner and the controller are told a noisy apex and see a noisy
terrain (filtered by the robot's ``map_filter``), the leg reaches a noisy angle, and the hops run on a hopper
whose stiffness, mass and friction differ from the model's; the true apex evolves on the true terrain. Every draw
comes from a generator seeded by the config's seed and the case's id (``case_seed``), so a case gives the same
result in any process and any order.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from drakeslip import ApexState, SlipParams
from drakeslip.rollout import rollout
from planners.replanning import ClosedLoopConfig, Replanner, case_result, case_seed, drawn_hopper


def run_case(planner, controller, case, goal_x: float, params: SlipParams,
             config: ClosedLoopConfig = ClosedLoopConfig()) -> dict:
    """One case (``case.id``, ``case.terrain``, ``case.apex``) in the receding-horizon loop; returns
    {"id", "success", "failure", "final_x", "plans"}, one record per planning call in "plans" (with the footholds
    and leg angles executed, and the apex the planner was told in "seen_apex" under noise; "executed_params" is
    then the hopper that ran). On the ``"multibody"`` backend the robot runs it, replanning at every
    ``executed_per_plan``-th apex (``_run_on_robot``); else the template, ``controller`` aiming its legs."""
    if config.backend == "multibody":
        return _run_on_robot(planner, case, goal_x, params, config)
    return _run_on_template(planner, controller, case, goal_x, params, config)


def _run_on_template(planner, controller, case, goal_x: float, params: SlipParams, config: ClosedLoopConfig) -> dict:
    """The loop on the template: each plan's first ``executed_per_plan`` footholds rolled out on
    ``config.backend``, from the apex the last rollout reached. Per plan, the noise draws come in this order: the
    apex errors and the leg-angle errors of its k hops, then the sensed map's."""
    apex, terrain = ApexState(*map(float, case.apex)), case.terrain
    noise = config.noise.for_hopper(params)
    rng = np.random.default_rng(case_seed(config.seed, case.id))
    executed = drawn_hopper(noise, params, rng)
    replanner = Replanner(planner, terrain, goal_x, params, noise, config.map_filter, raise_refusals=noise.silent)
    plans, hops, failure, k = [], 0, None, config.executed_per_plan
    while True:
        apex_errors = None if noise.silent else noise.apex_errors(rng, k)
        angle_errors = None if noise.silent else noise.angle_errors(rng, k)
        call = replanner.plan(apex, None if apex_errors is None else apex_errors[0], rng)
        plans.append(call.record)
        if call.plan is None or not (call.plan.success or call.plan.safe_hops is not None):
            failure, final_x = "NO_PLAN", apex.x
            break
        footholds = call.plan.to_fly(k).tolist()   # where no plan reaches the goal: its safe hops
        if not footholds:  # the robot believes it is past the goal already: it stops where it is
            failure, final_x = (None if apex.x >= goal_x else "STOPPED_SHORT"), apex.x
            break
        run = rollout(apex, terrain, executed, footholds=footholds, controller=controller, backend=config.backend,
                      apex_errors=apex_errors, angle_errors=angle_errors,
                      sensed_terrain=None if noise.silent else call.sensed)
        call.record["executed"] = [float(x) for x in run.footholds]
        call.record["leg_angles"] = [float(a) for a in run.leg_angles]   # as the leg reached them (with its errors)
        hops += len(footholds)
        if run.failure is not None:
            failure, final_x = run.failure.name, run.failure_x
            break
        apex = ApexState(*map(float, run.apexes[-1]))
        final_x = apex.x
        if apex.x >= goal_x:
            break
        if hops >= config.max_hops:
            failure = "HOP_CAP"
            break
    return case_result(case.id, failure, final_x, plans, None if noise.silent else executed)


def robot_config(config: ClosedLoopConfig, params: SlipParams) -> ClosedLoopConfig:
    """``config`` with, on the multibody backend, the robot and the template it runs for the hopper ``params`` made
    explicit: without a robot of its own, the robot of the hopper (``RobotParams.for_hopper``) planned for with
    ``config.template`` (fitted to the paper's hopper's robot) made that robot's
    (``drakeslip.multibody.fit.template_for``; ValueError for a learned correction on another hopper); a config
    with a robot of its own is taken as it is (its template, None: the hopper's own SLIP)."""
    from drakeslip.multibody.fit import template_for
    from drakeslip.multibody.robot import RobotParams

    if config.backend != "multibody" or config.robot is not None:
        return config
    template = template_for(params, config.template) if config.template is not None else None
    return replace(config, robot=RobotParams.for_hopper(params), template=template)


def _run_on_robot(planner, case, goal_x: float, params: SlipParams, config: ClosedLoopConfig) -> dict:
    """The loop on the multibody robot (``planners.drake_system.run_closed_loop``), the robot and the template of
    ``robot_config``; a template of None: the hopper ``params`` itself."""
    from planners.drake_system import run_closed_loop

    config = robot_config(config, params)
    result = run_closed_loop(planner, case, goal_x, config.template or params, config)
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
    and apexes of each Plan in ``plans`` (``PlanRecorder.plans``; its safe hops' where it found no plan), k the
    number of footholds its record of ``records`` (a run's "plans", on either backend) says were executed."""
    executed = [(plan.best if plan.success else plan.safe_hops, len(record["executed"]))
                for plan, record in zip(plans, records) if record.get("executed")]
    return [x for hops, k in executed for x in hops.footholds[:k]], [a for hops, k in executed for a in hops.apexes[:k]]
