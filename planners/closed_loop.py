"""The receding-horizon loop (paper, section VII): plan on the perception window, execute the first footholds of
the plan with the controller, replan from the apex reached; repeat until the body passes the goal, a failure, no
plan, or the hop cap."""
from __future__ import annotations

from dataclasses import dataclass

from drakeslip import ApexState, SlipParams
from drakeslip.rollout import BACKENDS, rollout

EXECUTED_PER_PLAN = 3   # footholds executed before replanning (the paper's protocol)
MAX_HOPS = 60           # a case that has not reached the goal after this many hops fails ("hop cap")


@dataclass(frozen=True)
class ClosedLoopConfig:
    """``executed_per_plan`` footholds of each plan are executed before replanning; ``backend="drake"`` executes on
    the Drake hybrid simulator (the protocol), ``"fast"`` on the fast step map (quick diagnosis: is a failure the
    planner's or the model mismatch's?); ``refine`` switches the controller's Newton polish (False: the MLP alone,
    as in the paper, an ablation)."""

    executed_per_plan: int = EXECUTED_PER_PLAN
    max_hops: int = MAX_HOPS
    backend: str = "drake"
    refine: bool = True

    def __post_init__(self):
        if self.backend not in BACKENDS:
            raise ValueError(f"backend must be one of {BACKENDS}, got {self.backend!r}")
        for name in ("executed_per_plan", "max_hops"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")


def run_case(planner, controller, case, goal_x: float, params: SlipParams,
             config: ClosedLoopConfig = ClosedLoopConfig()) -> dict:
    """One case (``case.id``, ``case.terrain``, ``case.apex``) in the receding-horizon loop; returns
    {"id", "success", "failure", "final_x", "plans"}, one record per planning call in "plans"."""
    apex, terrain = ApexState(*map(float, case.apex)), case.terrain
    plans, hops, failure = [], 0, None
    while True:
        plan = planner.plan(apex, terrain.perceived(apex.x), goal_x, params)
        record = plan.summary()
        record["apex"] = list(apex)
        plans.append(record)
        if not plan.success:
            failure = "NO_PLAN"
            final_x = apex.x
            break
        footholds = plan.footholds[:config.executed_per_plan].tolist()
        run = rollout(apex, terrain, params, footholds=footholds, controller=controller, backend=config.backend)
        record["executed"] = [float(x) for x in run.footholds]
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
    return {"id": case.id, "success": failure is None, "failure": failure, "final_x": final_x, "plans": plans}
