"""Receding-horizon evaluation (paper, section VII): plan on the perception window with the fast step map,
execute the first 3 footholds with the controller on the Drake hybrid simulator, replan from the apex
reached; repeat until the body passes the goal, a failure, no plan, or the hop cap.
"""
from __future__ import annotations

import hashlib
import json
import math
import statistics
from dataclasses import dataclass
from pathlib import Path

from drakeslip import ApexState, SlipParams, Terrain
from drakeslip.controller import DEFAULT_WEIGHTS, StepLengthController
from drakeslip.files import append_jsonl, atomic_write, open_jsonl_cache, read_jsonl_cache
from drakeslip.pool import results_of

from .presets import options_for
from .registry import make, planner_name, takes
from .suite import Case, Suite

EXECUTED_PER_PLAN = 3   # footholds executed before replanning (the paper's protocol)
MAX_HOPS = 60           # a case that has not reached the goal after this many hops fails ("hop cap")


@dataclass(frozen=True)
class EvalConfig:
    """``backend="drake"`` executes on the Drake hybrid simulator (the protocol); ``"fast"`` executes on the
    fast step map instead, for quick diagnosis (is a failure the planner's or the model mismatch's?).
    ``refine`` switches the controller's Newton polish (used by the Step-space planner and the execution)."""

    executed_per_plan: int = EXECUTED_PER_PLAN
    max_hops: int = MAX_HOPS
    backend: str = "drake"
    refine: bool = True   # False: the controller is the MLP alone, as in the paper (an ablation)

    def __post_init__(self):
        if self.backend not in ("drake", "fast"):
            raise ValueError(f"backend must be 'drake' or 'fast', got {self.backend!r}")


def perceived(terrain: Terrain, x_body: float) -> Terrain:
    """What the robot sees at x_body: the 8 m ahead / 3 m behind window as its own Terrain."""
    heights, x_start = terrain.window(x_body)
    return Terrain(heights, terrain.cell, x_start, terrain.ditch_height)


@dataclass
class _Executed:
    """What executing some footholds gave: the same fields the evaluation reads from a SimulationResult."""

    footholds: list
    apexes: list
    failure: object = None
    failure_x: float = float("nan")


def execute(apex: ApexState, footholds: list, controller: StepLengthController, terrain: Terrain,
            params: SlipParams, backend: str) -> _Executed:
    """Hop to each foothold in turn, the controller choosing the leg angle at every apex."""
    if backend == "drake":
        from drakeslip.simulate import simulate

        sim = simulate(apex, lambda a, hop: controller.leg_angle(a, footholds[hop], terrain), terrain, params,
                       max_hops=len(footholds), log=False)
        return _Executed(sim.footholds, sim.apexes, sim.failure,
                         sim.failure_event.state[0] if sim.failure is not None else float("nan"))
    from drakeslip import step

    done = _Executed([], [])
    for x_l in footholds:
        r = step(apex, controller.leg_angle(apex, x_l, terrain), terrain, params)
        if r.touchdown_x == r.touchdown_x:
            done.footholds.append(r.touchdown_x)
        if not r.ok:
            done.failure, done.failure_x = r.failure, r.end_state[0]
            break
        apex = r.next_apex
        done.apexes.append(apex)
    return done


def run_case(planner, controller: StepLengthController, case: Case, goal_x: float, params: SlipParams,
             config: EvalConfig = EvalConfig()) -> dict:
    """One case in the receding-horizon loop; returns {"id", "success", "failure", "final_x", "plans"}."""
    apex, terrain = ApexState(*map(float, case.apex)), case.terrain
    plans, hops, failure = [], 0, None
    while True:
        plan = planner.plan(apex, perceived(terrain, apex.x), goal_x, params)
        record = plan.summary()
        record["apex"] = list(apex)
        plans.append(record)
        if not plan.success:
            failure = "NO_PLAN"
            final_x = apex.x
            break
        footholds = plan.footholds[:config.executed_per_plan].tolist()
        sim = execute(apex, footholds, controller, terrain, params, config.backend)
        record["executed"] = [float(x) for x in sim.footholds]
        hops += len(footholds)
        if sim.failure is not None:
            failure = sim.failure.name
            final_x = float(sim.failure_x)
            break
        apex = ApexState(*map(float, sim.apexes[-1]))
        final_x = apex.x
        if apex.x >= goal_x:
            break
        if hops >= config.max_hops:
            failure = "HOP_CAP"
            break
    return {"id": case.id, "success": failure is None, "failure": failure, "final_x": final_x, "plans": plans}


def summarize(cases: list) -> dict:
    """The per-planner JSON block: success rate (fraction), ODE calls, nodes expanded and planning time per
    planning call, and the footholds per plan found (a search expands at least one node per foothold)."""
    calls = [p for c in cases for p in c["plans"]]
    times = [p["t_plan_s"] for p in calls]
    lengths = [len(p["footholds"]) for p in calls if p["success"]]
    return {"success_rate": sum(c["success"] for c in cases) / len(cases) if cases else 0.0,
            "ode_calls_mean": statistics.fmean(p["ode_calls"] for p in calls) if calls else 0.0,
            "ode_calls_median": statistics.median(p["ode_calls"] for p in calls) if calls else 0.0,
            "t_plan_mean_s": statistics.fmean(times) if times else 0.0,
            "t_plan_median_s": statistics.median(times) if times else 0.0,
            "nodes_expanded_mean": statistics.fmean(p["nodes_expanded"] for p in calls) if calls else 0.0,
            "footholds_mean": statistics.fmean(lengths) if lengths else 0.0,
            "cases": cases}


def table(results: dict) -> str:
    """A text table like the paper's Tables II/III."""
    w = max([12] + [len(name) for name in results["planners"]])
    rows = [f"Results on {results['suite']}",
            f"{'Planner':<{w}} {'Success %':>9} {'ODE calls':>10} {'ODE median':>10} {'t_plan mean':>12} "
            f"{'t_plan median':>14} {'nodes/plan':>10} {'steps/plan':>10} {'cases':>6}"]
    for name, r in results["planners"].items():
        rows.append(f"{name:<{w}} {100 * r['success_rate']:>9.1f} {r['ode_calls_mean']:>10.0f} "
                    f"{r['ode_calls_median']:>10.0f} "
                    f"{r['t_plan_mean_s']:>11.2g}s {r['t_plan_median_s']:>13.2g}s "
                    f"{r['nodes_expanded_mean']:>10.1f} {r['footholds_mean']:>10.1f} {len(r['cases']):>6}")
    return "\n".join(rows)


def ratios(results: dict, baseline: str) -> str:
    """The baseline planner's ODE calls and planning time per planning call over each other planner's, from one
    run: means, medians, and the mean time over calls that found a plan (a search that finds none runs to its
    budget, which is the same for every planner and can dominate a mean over few cases)."""
    if baseline not in results["planners"]:
        raise ValueError(f"baseline {baseline!r} is not among the results' planners {list(results['planners'])}")

    def stats(r):
        calls = [p for c in r["cases"] for p in c["plans"]]
        found = [p["t_plan_s"] for p in calls if p["success"]]
        return (r["ode_calls_mean"], r["ode_calls_median"], r["t_plan_mean_s"],
                statistics.fmean(found) if found else math.nan, r["t_plan_median_s"])

    base = stats(results["planners"][baseline])
    w = max([12] + [len(name) for name in results["planners"]])
    heads = ("ODE mean", "ODE median", "t_plan mean", "t mean, found", "t_plan median")
    rows = [f"{baseline} / planner, per planning call", f"{'Planner':<{w}} " + " ".join(f"{h:>13}" for h in heads)]
    for name, r in results["planners"].items():
        if name != baseline:
            cells = (b / x if x != 0 else math.inf for b, x in zip(base, stats(r)))
            rows.append(f"{name:<{w}} " + " ".join(f"{c:>12.2f}x" for c in cells))
    return "\n".join(rows)


# ---- parallel driver with a resumable per-case cache ---------------------------------------------------

_WORKER: dict = {}


def make_planners(planner_specs: dict, controller: StepLengthController | None = None) -> dict:
    """The planners of a run by label, sharing ``controller`` with those that take one; a preset label with no
    options gets the preset's (planners/presets.py). An option a planner does not take, or a bad value, is a
    ValueError naming the label."""
    planners = {}
    for label, opts in planner_specs.items():
        name = planner_name(label)
        shared = {"controller": controller} if controller is not None and takes(name, "controller") else {}
        try:
            planners[label] = make(name, **shared, **options_for(label, opts))
        except (TypeError, ValueError) as error:  # TypeError: an unknown keyword
            raise ValueError(f"options for {label}: {error}") from error
    return planners


def _init_worker(planner_specs: dict, controller_path, refine: bool):
    controller = StepLengthController.load(controller_path or DEFAULT_WEIGHTS, refine=refine)
    _WORKER["controller"] = controller
    _WORKER["planners"] = make_planners(planner_specs, controller)


def _run_task(label: str, case_dict: dict, goal_x: float, friction: float, config: EvalConfig):
    from .suite import suite_from_dict

    suite = suite_from_dict({"format": "drakeslip-suite/1", "name": "task", "goal_x": goal_x,
                             "friction": friction, "cases": [case_dict]})
    return run_case(_WORKER["planners"][label], _WORKER["controller"], suite.cases[0], goal_x,
                    SlipParams(friction=friction), config)


def _digest(path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:16] if path and Path(path).exists() else str(path)


def fingerprint(suite: Suite, planner: str, options: dict, config: EvalConfig, controller_path) -> str:
    """Identifies a (suite, planner, options, weights) run, so cached cases are reused only for the same setup:
    retraining the controller, the LSTM or another weights file an option names (the ranker), or the one a
    trajopt seed's planner reads, invalidates them."""
    weights, files = _files_read(planner, options)
    blob = json.dumps([suite.to_dict(), planner, options, config.__dict__, _digest(controller_path or DEFAULT_WEIGHTS),
                       weights] + ([files] if files else []), sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def _files_read(planner: str, options: dict, lstm_weights=None):
    """Digests of the files a planner built with these options reads: its LSTM checkpoint (lstm and lstm-guided;
    Angle- and Step-space's ``weights`` are cost weights) and every other option naming a file; for trajopt,
    also its seed planner's (the seed's preset or ``seed_options``, the config's ``lstm_weights``)."""
    name, weights = planner_name(planner), None
    if name in ("lstm", "lstm-guided"):
        from .lstm_planner import DEFAULT_WEIGHTS as LSTM_WEIGHTS

        weights = _digest(options.get("weights") or lstm_weights or LSTM_WEIGHTS)
    files = {k: _digest(v) for k, v in options.items() if k != "weights" and isinstance(v, str) and Path(v).is_file()}
    if name == "trajopt":
        seed = options.get("seed", "step")
        files["seed"] = _files_read(seed, options_for(seed, options.get("seed_options")),
                                    getattr(options.get("config"), "lstm_weights", None))
    return weights, files


def load_cache(path: Path) -> dict:
    """{(fingerprint, case id): result} from the JSON-lines cache."""
    return read_jsonl_cache(path, lambda e: (e["key"], e["result"]["id"]), lambda e: e["result"])


def evaluate(suite: Suite, planner_specs: dict, n_cases: int | None = None, jobs: int = 1,
             cache_path=None, controller_path=None, config: EvalConfig = EvalConfig(), progress: bool = True,
             every: int = 1) -> dict:
    """Run every planner on every ``every``-th case, the first ``n_cases`` of those (all if None), ``jobs``
    processes. Finished cases are appended to ``cache_path`` (JSON lines) as they complete and skipped when
    the run is started again."""
    from tqdm import tqdm

    if not (isinstance(every, int) and every >= 1):
        raise ValueError(f"every must be a positive integer, got {every!r}")
    cases = list(suite.cases[::every])[:n_cases]
    planner_specs = {label: options_for(label, opts) for label, opts in planner_specs.items()}
    _init_worker(planner_specs, controller_path, config.refine)  # in this process: bad options fail before any case
    keys = {name: fingerprint(suite, name, opts, config, controller_path) for name, opts in planner_specs.items()}
    cache_path = Path(cache_path) if cache_path else None
    cache = load_cache(cache_path) if cache_path else {}
    done = {name: {} for name in planner_specs}
    todo = []
    for name in planner_specs:
        for c in cases:
            hit = cache.get((keys[name], c.id))
            if hit is not None:
                done[name][c.id] = hit
            else:
                todo.append((name, c))
    bar = tqdm(total=len(todo), desc=f"{suite.name}", disable=not progress, unit="case")
    sink = open_jsonl_cache(cache_path) if cache_path else None
    try:
        payload = lambda c: {"id": c.id, "terrain": c.terrain.to_dict(), "apex": c.apex._asdict()}
        tasks = [(name, (name, payload(c), suite.goal_x, suite.friction, config)) for name, c in todo]
        for name, result in results_of(_run_task, tasks, jobs, _init_worker,
                                       (planner_specs, controller_path, config.refine)):
            done[name][result["id"]] = result
            if sink:
                append_jsonl(sink, {"key": keys[name], "result": result})
            bar.update(1)
            bar.set_postfix({n: f"{sum(r['success'] for r in d.values())}/{len(d)}" for n, d in done.items()})
    finally:
        bar.close()
        if sink:
            sink.close()
    return {"suite": suite.name,
            "planners": {name: summarize([done[name][c.id] for c in cases]) for name in planner_specs}}


def write_json(results: dict, path) -> None:
    """Write atomically: a temporary file renamed over the target."""
    with atomic_write(path, "w") as f:
        json.dump(results, f, indent=1)
