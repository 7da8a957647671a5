"""The record of one case run in the receding-horizon loop (``planners.closed_loop.run_case``, and on the robot
``planners.drake_system.run_closed_loop``), as results files and the evaluation's case cache hold it, and its check:
a record read back from a cache is used as the code reads it (``verification.report.summarize``, the results
table, examples/compare_results.py), so one of the wrong shape, a field of the wrong type included, is refused
here, in one line naming the field, rather than raising deep inside a table."""
from __future__ import annotations

import numbers

from planners.base import Timing

TIMING_PARTS = tuple(Timing().record())   # the keys of a plan record's "timing"


def check_case_record(record) -> dict:
    """``record`` if it is a case record: "id" (a string), "success" (a boolean), "failure" (null or a string),
    "final_x" (a number), "plans" (a list of plan records, ``check_plan_record``), and optionally
    "executed_params" (numbers by name) and the robot's "what", "hops", "max_pitch", "simulated_s", "wall_s";
    else ValueError naming the first bad field."""
    require(isinstance(record, dict), "the result", "an object", record)
    for name, kind, test in (("id", "a string", is_text), ("success", "true or false", is_flag),
                             ("failure", "null or a string", lambda v: v is None or is_text(v)),
                             ("final_x", "a number", is_number), ("plans", "a list", is_list)):
        field(record, name, kind, test)
    for k, plan in enumerate(record["plans"]):
        check_plan_record(plan, f"plans[{k}]")
    optional(record, "executed_params", "an object of numbers",
             lambda v: isinstance(v, dict) and all(is_number(x) for x in v.values()))
    optional(record, "what", "a string", is_text)
    optional(record, "hops", "a count", is_count)
    for name in ("max_pitch", "simulated_s", "wall_s"):
        optional(record, name, "a number", is_number)
    return record


def check_plan_record(plan, where: str) -> None:
    """ValueError naming the field unless ``plan`` is a planning call's record (``Plan.summary`` with the apex it
    planned from, and what the loop executed of it)."""
    require(isinstance(plan, dict), where, "an object", plan)
    for name, kind, test in (("success", "true or false", is_flag), ("message", "a string", is_text),
                             ("ode_calls", "a count", is_count), ("nodes_expanded", "a count", is_count),
                             ("t_plan_s", "a number", is_number), ("target_x", "a number", is_number),
                             ("footholds", "a list of numbers", is_numbers), ("apex", "3 numbers", is_apex)):
        field(plan, name, kind, test, where)
    optional(plan, "time_limited", "true or false", is_flag, where)
    optional(plan, "timing", f"an object of numbers by {', '.join(TIMING_PARTS)}",
             lambda v: isinstance(v, dict) and tuple(sorted(v)) == tuple(sorted(TIMING_PARTS))
             and all(is_number(x) for x in v.values()), where)
    optional(plan, "seen_apex", "3 numbers", is_apex, where)
    for name in ("executed", "leg_angles"):
        optional(plan, name, "a list of numbers", is_numbers, where)
    optional(plan, "pumped", "a number", is_number, where)
    optional(plan, "in_place", "true or false", is_flag, where)


def field(record: dict, name: str, kind: str, test, where: str = "") -> None:
    if name not in record:
        raise KeyError(f"{where}.{name}" if where else name)
    require(test(record[name]), f"{where}.{name}" if where else name, kind, record[name])


def optional(record: dict, name: str, kind: str, test, where: str = "") -> None:
    if name in record:
        field(record, name, kind, test, where)


def require(ok: bool, name: str, kind: str, value) -> None:
    if not ok:
        text = repr(value)
        raise ValueError(f"{name} must be {kind}, got {text if len(text) <= 40 else text[:16] + '...'}")


def is_flag(value) -> bool:
    return isinstance(value, bool)


def is_text(value) -> bool:
    return isinstance(value, str)


def is_number(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def is_count(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and value >= 0


def is_list(value) -> bool:
    return isinstance(value, list)


def is_numbers(value) -> bool:
    return isinstance(value, list) and all(is_number(x) for x in value)


def is_apex(value) -> bool:
    return is_numbers(value) and len(value) == 3
