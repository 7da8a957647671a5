"""The trajectory optimization as a planner (``planners.make("trajopt", seed=...)``), and the planning query the
suites give (``make_problem``)."""
from __future__ import annotations

import time

import numpy as np

from drakeslip import SlipParams, Terrain
from planners.base import FootstepSequence, Plan, Planner, Problem
from planners.registry import files_read, planner_name
from planners.trajopt.config import TrajoptConfig, as_config
from planners.trajopt.seeds import check_seed
from planners.trajopt.solve import optimize


class TrajoptPlanner(Planner):
    """The trajectory optimization as a planner: footholds from ``seed``, optimized; the plan carries the
    optimized leg angles and apexes (``plan.success`` means the solver converged, not that Drake verified).
    Its ``ode_calls`` are the seed planner's step-map calls and the initial guess's (one per hop; none are
    counted when the seed finds no plan); the collocation's own evaluations of the SLIP equations are not
    step-map calls. It does not stop at ``max_time_s``: the seed planner has its own default budget and the
    solve runs to ``config.major_iterations`` (SNOPT's "Time limit" option had no effect when tried).
    ``seed_options``: options for the seed's planner (see ``seed_footholds``); ``config``: a TrajoptConfig or its
    fields as a dict (``config.as_config``), as the ``trajopt@robust`` preset gives it."""

    name = "trajopt"

    def __init__(self, seed: str = "step", config: TrajoptConfig | dict | None = None,
                 seed_options: dict | None = None, **budget):
        super().__init__(**budget)
        self.config = as_config(config)
        check_seed(seed, seed_options, self.config)
        self.seed, self.seed_options = seed, seed_options

    @classmethod
    def files_read(cls, options: dict) -> dict:
        """The files its seed's planner reads (none for the cold gait), as ``seed.OPTION``."""
        seed = options.get("seed", "step")
        if planner_name(seed) == "cold":
            return {}
        seed_options = dict(options.get("seed_options") or {})
        config = as_config(options.get("config"))
        if config.seed_model and planner_name(seed).startswith("lstm") and "model" not in seed_options:
            seed_options["model"] = config.seed_model
        return {f"seed.{k}": v for k, v in files_read(seed, seed_options).items()}

    def _plan(self, problem: Problem) -> Plan:
        record = optimize(problem, self.seed, self.config, verify_on_drake=False, seed_options=self.seed_options)
        if record["error"] or not record["converged"]:
            return Plan(self.name, False, problem.target_x, ode_calls=record.get("ode_calls", 0),
                        message=f"no plan found: {record['error'] or record.get('status')}")
        seq = FootstepSequence(np.array(record["footholds"]), np.array(record["leg_angles"]),
                               np.array(record["apexes"][1:]))
        return Plan(self.name, True, problem.target_x, ode_calls=record["ode_calls"],
                    message=record.get("status", ""), sequences=[seq])


def make_problem(apex, terrain: Terrain, goal_x: float, params: SlipParams | None = None) -> Problem:
    """The planning query the suites give: the perception-window problem (window end, target) of a Planner."""
    return TrajoptPlanner().problem(apex, terrain, goal_x, params, time.perf_counter())
