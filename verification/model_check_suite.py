"""The model-checking oracle on a suite: each case's verdict (``model_check``), cached and run by the job runner,
the suite's ceiling, and the cross-check against planners' results."""
from __future__ import annotations

import hashlib
import json
import random
from dataclasses import asdict

import numpy as np

from drakeslip import SlipParams
from drakeslip.jobs.runner import JsonLinesStore, run

from planners.base import Budget
from planners.formats.case_record import field, is_number, require
from planners.formats.suite import Case, Suite, terrain_record
from planners.formats.suite_draw import suite_hopper
from verification.model_check import (DEFAULT_BUDGET, LEVELS, MAX_WITNESSES, NOT_TRAVERSABLE,
                                      PROVED_NOT_TRAVERSABLE, TRAVERSABLE, UNKNOWN,
                                      model_check, resolution_text)
from verification.provenance import code_version

VERDICTS = (TRAVERSABLE, NOT_TRAVERSABLE, PROVED_NOT_TRAVERSABLE, UNKNOWN)


def select_cases(suite: Suite, n_cases: int | None = None, seed: int | None = None, ids=None) -> list[Case]:
    """The cases named by ``ids``; else ``n_cases`` of them (the first ones, or a random sample if ``seed`` is
    given); else all."""
    if ids:
        by_id = {c.id: c for c in suite.cases}
        unknown = [i for i in ids if i not in by_id]
        if unknown:
            raise ValueError(f"unknown case id(s) {unknown} in suite {suite.name!r} "
                             f"(its ids look like {suite.cases[0].id!r})")
        return [by_id[i] for i in ids]
    if n_cases is not None and (isinstance(n_cases, bool) or not isinstance(n_cases, int) or n_cases < 1):
        raise ValueError(f"the number of cases must be a positive integer, got {n_cases!r}")
    n = min(n_cases or len(suite.cases), len(suite.cases))
    if seed is None:
        return list(suite.cases[:n])
    picked = sorted(random.Random(seed).sample(range(len(suite.cases)), n))
    return [suite.cases[i] for i in picked]


def _config(levels, min_speed, drake_check, max_witnesses, energy=True, confirm=False) -> dict:
    return {"levels": [asdict(r) for r in levels], "min_speed": min_speed, "drake_check": drake_check,
            "max_witnesses": max_witnesses, "energy": energy, "confirm": confirm}


def case_key(case: Case, goal_x: float, params: SlipParams, config: dict) -> str:
    """Identifies a case, the hopper (with the suite's friction) and the oracle's settings (not its budget), so a
    cached verdict is reused only for the same question."""
    blob = json.dumps([terrain_record(case.terrain), list(case.apex), goal_x, asdict(params), config],
                      sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def check_verdict_record(record) -> None:
    """ValueError naming the field (KeyError for one missing) unless ``record`` is a verdict as ``check_suite`` reads
    one back from its cache: "verdict" one of VERDICTS, "time_s" a number, "holds_at" null or an object, "budget"
    its "max_nodes" and "max_time_s" as numbers (the case record's checks, ``planners.formats.case_record``)."""
    require(isinstance(record, dict), "the verdict", "an object", record)
    for name, kind, test in (("verdict", f"one of {VERDICTS}", VERDICTS.__contains__),
                             ("time_s", "a number", is_number),
                             ("holds_at", "null or an object", lambda v: v is None or isinstance(v, dict)),
                             ("budget", "an object of max_nodes and max_time_s",
                              lambda v: isinstance(v, dict) and all(is_number(v.get(k))
                                                                    for k in ("max_nodes", "max_time_s")))):
        field(record, name, kind, test)


def summarize(records: list) -> dict:
    """Counts by verdict: ``not_traversable`` is both kinds, ``proved_not_traversable`` (the energy argument, any
    leg angles) plus ``not_traversable_grid`` (exhausted grids), the latter also by ``holds_at`` resolution;
    ``unknown_why`` counts the unknowns by reason."""
    n = len(records)
    count = {v: sum(r["verdict"] == v for r in records)
             for v in (TRAVERSABLE, NOT_TRAVERSABLE, PROVED_NOT_TRAVERSABLE, UNKNOWN)}
    resolutions, why = {}, {}
    for r in records:
        if r["verdict"] == NOT_TRAVERSABLE:
            text = resolution_text(r["holds_at"])
            resolutions[text] = resolutions.get(text, 0) + 1
        elif r["verdict"] == UNKNOWN:
            why[r.get("why")] = why.get(r.get("why"), 0) + 1
    return {"cases": n, "traversable": count[TRAVERSABLE],
            "not_traversable": count[NOT_TRAVERSABLE] + count[PROVED_NOT_TRAVERSABLE],
            "proved_not_traversable": count[PROVED_NOT_TRAVERSABLE], "not_traversable_grid": count[NOT_TRAVERSABLE],
            "grid_holds_at": resolutions, "unknown": count[UNKNOWN], "unknown_why": why,
            "decided_rate": (n - count[UNKNOWN]) / n if n else 0.0,
            # the suite's best possible success rate; with unknowns it lies between ceiling and ceiling_upper
            "ceiling": count[TRAVERSABLE] / n if n else 0.0,
            "ceiling_upper": (count[TRAVERSABLE] + count[UNKNOWN]) / n if n else 0.0,
            "time_s_median": float(np.median([r["time_s"] for r in records])) if n else 0.0}


# many parameters: the suite and cases, then ``model_check``'s keyword options and the run's, each with its default
def check_suite(suite: Suite, cases: list[Case], cache_path=None, budget: Budget = DEFAULT_BUDGET,
                levels=LEVELS, min_speed: float | None = None, drake_check: bool = True,
                max_witnesses: int = MAX_WITNESSES, progress: bool = True, executor=None, energy: bool = True,
                confirm: bool = False, parallel: bool = False, code: str | None = None) -> dict:
    """Run the oracle on ``cases`` of ``suite`` on ``executor`` (``drakeslip.jobs.executors``; default this
    process). Each finished case is appended to ``cache_path`` (JSON lines) and reused by a later run of the same
    code (``code``, default ``code_version()``) with the same settings; a cached ``unknown`` is rerun when the
    budget grew, and a damaged cached verdict (``check_verdict_record``) is skipped with a warning and run again.
    The time budget is wall-clock per case, so an executor should run no more cases at a time than it has cores
    (``parallel``: one case at a time, each spreading its hops over every core)."""
    from tqdm import tqdm

    config = _config(levels, min_speed, drake_check, max_witnesses, energy, confirm)
    params = suite_hopper(suite).params.with_friction(suite.friction)   # the suite's hopper on the suite's ground
    keys = {c.id: case_key(c, suite.goal_x, params, config) for c in cases}
    first = {}
    for c in cases:  # identical cases ask the same question: checked once
        first.setdefault(keys[c.id], c)
    options = {"levels": levels, "budget": budget, "min_speed": min_speed, "drake_check": drake_check,
               "max_witnesses": max_witnesses, "energy": energy, "confirm": confirm, "parallel": parallel}
    tasks = [(key, (c.apex, c.terrain, suite.goal_x, params, options)) for key, c in first.items()]

    def reuse(held):  # a cached "unknown", or an unconfirmed "not-traversable", is rerun when the budget grew
        return (held["verdict"] != UNKNOWN and not (held.get("holds_at") or {}).get("unconfirmed")) or (
            held["budget"]["max_nodes"] >= budget.max_nodes and held["budget"]["max_time_s"] >= budget.max_time_s)

    records = {}
    store = JsonLinesStore(cache_path, check_verdict_record, code or code_version()) if cache_path else None
    with tqdm(total=len(tasks), desc=f"model check {suite.name}", unit="case", disable=not progress) as bar:
        for key, result in run(_checked, tasks, store, executor, reuse=reuse):
            records[key] = result
            bar.update(1)
            s = summarize(list(records.values()))
            bar.set_postfix(T=s["traversable"], N=s["not_traversable"], U=s["unknown"])
    ordered = [{**records[keys[c.id]], "id": c.id} for c in cases]
    return {"suite": suite.name, "goal_x": suite.goal_x, "friction": suite.friction, "config": config,
            "cases": ordered, "summary": summarize(ordered)}


def _checked(apex, terrain, goal_x, params, options: dict) -> dict:
    """One case's verdict with the budget it had (a task of ``check_suite``): ``options`` are ``model_check``'s
    keyword options."""
    return {**model_check(apex, terrain, goal_x, params, **options), "budget": asdict(options["budget"])}


def cross_check(oracle: dict, evaluation: dict) -> dict:
    """Soundness against planners: for each planner of an ``examples/evaluate.py`` results dict, the cases it
    crossed that the oracle proved not traversable (``contradicted``: must be empty, a proof holds for any leg
    angles), the cases it crossed that the oracle calls not traversable at grid resolution (``off_grid``: a plan the
    grid misses, with leg angles between its own; that verdict claims no more) and the cases it failed that the
    oracle calls traversable (``missed``). Only cases both files hold are compared."""
    verdicts = {c["id"]: c["verdict"] for c in oracle["cases"]}
    out = {}
    for name, block in evaluation["planners"].items():
        cases = [c for c in block["cases"] if c["id"] in verdicts]
        out[name] = {"compared": len(cases), "crossed": sum(c["success"] for c in cases),
                     "contradicted": [c["id"] for c in cases
                                      if c["success"] and verdicts[c["id"]] == PROVED_NOT_TRAVERSABLE],
                     "off_grid": [c["id"] for c in cases if c["success"] and verdicts[c["id"]] == NOT_TRAVERSABLE],
                     "missed": [c["id"] for c in cases if not c["success"] and verdicts[c["id"]] == TRAVERSABLE]}
    return out
