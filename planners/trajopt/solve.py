"""One query end to end (``optimize``): seed, assign segments, build the program, solve it from the initial
guess, and check the solution on Drake (``verify``).

If the solver does not converge from the re-anchored guess it tries once more with the plain chained one; a stop
close to feasible is solved once more from its own point (polish). Every solution is checked by simulating its
leg angles open loop on the Drake hybrid simulator (``drakeslip.rollout``, Drake backend) on the true terrain: no
failure in its N hops and the last apex past the target. With several starts (``TrajoptConfig.starts``) the cold
and LSTM-guided seeds propose new footholds (other strides, other samples) until a start is verified.
"""
from __future__ import annotations

import math
import time

import numpy as np

from drakeslip import SlipParams, Terrain
from drakeslip.rollout import rollout
from planners.base import Problem
from planners.registry import planner_name
from planners.trajopt.config import MULTI_START, TrajoptConfig, TrajoptError
from planners.trajopt.guess import build_guess
from planners.trajopt.program import SlipTrajopt
from planners.trajopt.seeds import seed_footholds
from planners.trajopt.segments import assign_segments


def verify(apex, leg_angles, terrain: Terrain, params: SlipParams, target_x: float) -> dict:
    """Simulate the leg angles open loop on the Drake hybrid simulator. Verified: all hops complete with no
    failure and the last apex passes ``target_x``."""
    angles = [float(a) for a in leg_angles]
    if not angles or not all(abs(a) < math.pi / 2 for a in angles):
        return {"verified": False, "failure": "BAD_ANGLE", "footholds": [], "hops": 0}
    run = rollout(apex, terrain, params, leg_angles=angles, backend="drake")
    done = len(run.apexes)
    passed = done > 0 and run.apexes[-1].x >= target_x
    ok = run.ok and done == len(angles) and passed
    failure = run.failure.name if run.failure is not None else None
    reason = failure or ("" if done == len(angles) else "INCOMPLETE") or ("" if passed else "SHORT_OF_TARGET")
    return {"verified": ok, "failure": reason or None, "footholds": [float(x) for x in run.footholds], "hops": done,
            "final_apex": list(run.apexes[-1]) if run.apexes else None,
            "failure_x": run.failure_x if run.failure is not None else None}


def optimize(problem: Problem, seed: str | np.ndarray, config: TrajoptConfig | None = None,
             true_terrain: Terrain | None = None, verify_on_drake: bool = True,
             seed_options: dict | None = None) -> dict:
    """Seed, build, solve and verify one query. ``seed`` is a seed name (or ``NAME@VARIANT`` with
    ``seed_options`` for its planner, see ``seed_footholds``) or an array of footholds; the problem's
    terrain is what the seed and the optimizer see (the perception window), ``true_terrain`` (default: the
    same) what the solution is verified on. Returns a JSON-ready record: ``converged`` (the solver found a
    locally optimal, feasible point), ``drake_ok`` (its leg angles pass ``verify``) and ``verified`` (both: a
    plan the optimizer stands by and Drake confirms). A seed that gives nothing to optimize is reported with
    ``error`` set, not raised.

    With ``config.starts`` > 1 a named seed that can propose more than one start (``MULTI_START``) is tried
    again from its next start until one is verified (converged, without Drake): the record is the last start's,
    with ``starts`` listing every start's outcome and ``seed_time_s``, ``solve_time_s`` and ``iterations``
    adding up all of them."""
    config = config or TrajoptConfig()
    n = config.starts if isinstance(seed, str) and planner_name(seed) in MULTI_START else 1
    starts = []
    for sample in range(n):
        record = optimize_start(problem, seed, sample, config, true_terrain, verify_on_drake, seed_options)
        starts.append(record)
        if record["verified"] or (record["converged"] and not verify_on_drake):
            break
    if n == 1:
        return record
    record = dict(record)
    record["seed_time_s"] = sum(r.get("seed_time_s", 0.0) for r in starts)
    record["ode_calls"] = sum(r.get("ode_calls", 0) for r in starts)
    solved = [r for r in starts if r.get("solve_time_s") is not None]
    if solved:
        record.update(_total_cost(solved))
    record["starts"] = [{"sample": k, "error": r["error"], "converged": r["converged"], "verified": r["verified"],
                         "status": r.get("status"), "solve_time_s": r.get("solve_time_s"),
                         "iterations": r.get("iterations")} for k, r in enumerate(starts)]
    return record


def _total_cost(solves: list) -> dict:
    """Solver time and iterations added up over several solves (iterations None if any solve lacks them)."""
    iterations = [r["iterations"] for r in solves]
    return {"solve_time_s": sum(r["solve_time_s"] for r in solves),
            "iterations": None if None in iterations else sum(iterations)}


def optimize_start(problem: Problem, seed, sample: int, config: TrajoptConfig, true_terrain, verify_on_drake,
                   seed_options):
    """One start of ``optimize``. The solver starts from the re-anchored guess (``build_guess``); when that does
    not converge and the seed did not execute as it is, it starts once more from the chained guess
    (``config.retry``). A last attempt that stops unconverged but within ``config.polish_violation`` of feasible
    (SNOPT's "numerical difficulties" or its iteration limit, typically) is restarted from its own point, with a
    fresh Hessian approximation. ``solve_time_s`` and ``iterations`` add up every attempt."""
    record = {"seed": seed if isinstance(seed, str) else "footholds", "target_x": problem.target_x,
              "converged": False, "verified": False, "error": None}
    config = config.for_hopper(problem.units)
    t0 = time.perf_counter()
    try:
        if isinstance(seed, str):
            footholds, seed_calls = seed_footholds(seed, problem, config.max_hops, config.seed_model, sample,
                                                   seed_options)
        else:
            footholds, seed_calls = np.asarray(seed, dtype=np.float64).reshape(-1), 0
    except TrajoptError as exc:
        record.update(error=str(exc), seed_time_s=time.perf_counter() - t0)
        return record
    record["seed_time_s"] = time.perf_counter() - t0
    record["ode_calls"] = seed_calls
    footholds = footholds[:config.max_hops]
    record["seed_footholds"] = footholds.tolist()
    record["hops"] = int(footholds.size)
    try:
        segs = assign_segments(problem.terrain, footholds, config.edge_margin, problem.window_end)
    except TrajoptError as exc:
        record["error"] = str(exc)
        return record
    program = SlipTrajopt(problem.apex, problem.terrain, segs, problem.params, problem.target_x, config)
    attempts = []
    for reanchor in (True, False):
        guess = build_guess(problem.apex, footholds, segs, problem.terrain, problem.params, config.node_times(),
                            reanchor=reanchor)
        record["ode_calls"] += footholds.size  # the guess executes each foothold once on the fast step map
        if reanchor:
            record["seed_fast_ok"] = guess.fast_ok
            record["seed_fast_failure"] = guess.fast_failure
        result = program.solve(guess)
        attempts.append({"guess": "re-anchored" if reanchor else "chained", "converged": result.converged,
                         "status": result.status, "iterations": result.iterations,
                         "solve_time_s": result.solve_time_s})
        if result.converged or guess.fast_ok or not config.retry:  # (a seed that executes has one guess)
            break
    if not result.converged and 0 < config.polish_violation and result.max_violation <= config.polish_violation:
        result = program.solve(result.x)
        attempts.append({"guess": "polish", "converged": result.converged, "status": result.status,
                         "iterations": result.iterations, "solve_time_s": result.solve_time_s})
    record.update(result.summary())
    record.update(_total_cost(attempts))  # what the query cost: every attempt's solver time and iterations
    record["attempts"] = attempts
    if verify_on_drake:
        check = verify(problem.apex, result.leg_angles, true_terrain or problem.terrain, problem.params,
                       problem.target_x)
        record["drake_ok"] = bool(check["verified"])
        record["verified"] = bool(check["verified"]) and result.converged  # a plan the optimizer stands by
        record["verification"] = check
    return record
