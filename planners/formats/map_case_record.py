"""The record of one case run on a height map (``planners.spatial_loop.run_map_case``), as results files and the
evaluation's case cache hold it, and its check (the planar record's is ``planners.formats.case_record``): a record
read back from a cache is refused in one line naming its first bad field rather than raising inside a table."""
from __future__ import annotations

from planners.formats.case_record import (TIMING_PARTS, field, is_count, is_flag, is_list, is_number, is_numbers,
                                          is_text, optional, require)


def check_map_case_record(record) -> dict:
    """``record`` if it is a map case's record: "id" (a string), "success" (a boolean), "failure" (null or a
    string), "final_x" (a number), "final" (x, y), "plans" (a list of map plan records, ``check_map_plan_record``);
    else ValueError (or KeyError) naming the first bad field."""
    require(isinstance(record, dict), "the result", "an object", record)
    for name, kind, test in (("id", "a string", is_text), ("success", "true or false", is_flag),
                             ("failure", "null or a string", lambda v: v is None or is_text(v)),
                             ("final_x", "a number", is_number), ("final", "2 numbers", numbers_of(2)),
                             ("plans", "a list", is_list)):
        field(record, name, kind, test)
    for k, plan in enumerate(record["plans"]):
        check_map_plan_record(plan, f"plans[{k}]")
    return record


def check_map_plan_record(plan, where: str) -> None:
    """ValueError naming the field unless ``plan`` is a planning call's record on a map (``Plan.summary`` with the
    apex (x, y, z, xdot, ydot) it planned from and the footholds (x, y, z) the loop executed of it; where it found
    nothing and the loop flew on along the last plan found, "flies_on", how many footholds of that plan were left)."""
    require(isinstance(plan, dict), where, "an object", plan)
    for name, kind, test in (("success", "true or false", is_flag), ("message", "a string", is_text),
                             ("ode_calls", "a count", is_count), ("nodes_expanded", "a count", is_count),
                             ("t_plan_s", "a number", is_number), ("target_x", "a number", is_number),
                             ("footholds", "a list of (x, y, z)", points), ("apex", "5 numbers", numbers_of(5)),
                             ("executed", "a list of (x, y, z)", points)):
        field(plan, name, kind, test, where)
    optional(plan, "time_limited", "true or false", is_flag, where)
    optional(plan, "flies_on", "a count", is_count, where)
    optional(plan, "target_y", "a number", is_number, where)
    optional(plan, "timing", f"an object of numbers by {', '.join(TIMING_PARTS)}",
             lambda v: isinstance(v, dict) and tuple(sorted(v)) == tuple(sorted(TIMING_PARTS))
             and all(is_number(x) for x in v.values()), where)


def numbers_of(count: int):
    """A test: a list of ``count`` numbers."""
    return lambda value: is_numbers(value) and len(value) == count


def points(value) -> bool:
    """A list of (x, y, z) points, each a list of 3 numbers."""
    return isinstance(value, list) and all(numbers_of(3)(p) for p in value)
