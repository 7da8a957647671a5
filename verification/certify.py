"""Are a planner's plans what they say? Each case's first plan (from its start apex, on its perception window),
saved as a plan file would save it and checked on Drake (``plan_check``): certified, or the first mismatch."""
from __future__ import annotations

from drakeslip import SlipParams, StepLengthController
from drakeslip.hopper_file import hopper_for, params_from_fields
from drakeslip.state import SimulationCrash
from drakeslip.units import units_of

from planners.formats.case_record import field, is_count, is_text, require
from planners.formats.plan import PlanRecord
from planners.formats.suite import suite_from_dict
from planners.registry import make_planners
from verification.plan_check import check_plan

_WORKER: dict = {}


def prepare(specs: dict) -> None:
    """Build the planners of ``specs`` (label -> options) in this process (a worker's setup)."""
    controller = StepLengthController.load_default()
    _WORKER.update(controller=controller, planners=make_planners(specs, controller))


VERDICTS = ("certified", "counterexample", "no plan", "malformed", "simulation stopped")


def check_record(record) -> None:
    """ValueError naming the field (KeyError for one missing) unless ``record`` is what ``certify_case`` returns, as
    a cache holds it: "label", "id", "reason" strings, "verdict" one of VERDICTS, "hops" a count, "kind" null or a
    string, "hop" null or a count (the case record's checks, ``planners.formats.case_record``)."""
    require(isinstance(record, dict), "the record", "an object", record)
    for name, kind, test in (("label", "a string", is_text), ("id", "a string", is_text),
                             ("reason", "a string", is_text), ("verdict", f"one of {VERDICTS}", VERDICTS.__contains__),
                             ("hops", "a count", is_count),
                             ("kind", "null or a string", lambda v: v is None or is_text(v)),
                             ("hop", "null or a count", lambda v: v is None or is_count(v))):
        field(record, name, kind, test)


def certify_case(label: str, case: dict, goal_x: float, friction: float, mode: str, tolerance: float,
                 hopper: dict | None = None) -> dict:
    """{"label", "id", "verdict", "reason", "hops", "kind", "hop"} for the first plan of ``label`` on ``case`` (a
    suite's case entry) for the hopper whose SlipParams fields are ``hopper`` (None: the paper's) on ground of
    ``friction``: "certified", "counterexample" (with its reason), "no plan", "malformed" (a plan the plan-file
    format refuses: its fields disagree, with the reason), or "simulation stopped" (the check's simulation crashed
    or timed out before a verdict, ``SimulationCrash``, with its message)."""
    suite = suite_from_dict({"format": "drakeslip-suite/1", "name": "case", "goal_x": goal_x, "friction": friction,
                             "cases": [case]})
    body = SlipParams() if hopper is None else params_from_fields(hopper, "the task's hopper")
    c, params = suite.cases[0], body.with_friction(friction)
    perceived = c.terrain.perceived(c.apex.x, *units_of(params).window)
    plan = _WORKER["planners"][label].plan(c.apex, perceived, goal_x, params)
    record = {"label": label, "id": c.id, "kind": None, "hop": None}
    if not plan.success:
        return {**record, "verdict": "no plan", "reason": plan.message, "hops": 0}
    try:
        written = PlanRecord.from_plan(plan, c.apex, c.terrain, goal_x, params, hopper_for(params))
    except ValueError as malformed:
        return {**record, "verdict": "malformed", "reason": str(malformed), "hops": len(plan.footholds)}
    try:
        result = check_plan(written, mode, tolerance, controller=_WORKER["controller"])
    except SimulationCrash as stopped:
        return {**record, "verdict": "simulation stopped", "reason": str(stopped), "hops": len(plan.footholds)}
    if result.ok:
        return {**record, "verdict": "certified", "reason": "", "hops": len(result.footholds)}
    return {**record, "verdict": "counterexample", "reason": result.reason(), "hops": len(plan.footholds),
            "kind": result.kind, "hop": result.hop}
