"""Compare two results files of examples/evaluate.py case by case: outcomes, footholds, and the work per plan.

    python3 examples/compare_results.py out/before.json out/after.json
    python3 examples/compare_results.py out/before.json out/after.json --rename lstm@paper=lstm --fields outcome

For every planner label in both files (``--rename OLD=NEW`` pairs a label of the first file with another name in
the second) and every case in both, it compares the outcome (success, failure, final x), each planning call's
footholds, executed footholds and success, and, unless ``--fields outcome``, its ODE calls and nodes expanded
(``--fields found-work``: only for the calls that found a plan, when the two runs searched to other budgets).
Exit 0 when everything compared is identical, 1 when something differs (the first differences are printed),
2 for a usage or input error.
"""
from __future__ import annotations

import sys

from drakeslip.jobs import cli
from drakeslip.jobs.files import read_json

FIELDS = ("outcome", "found-work", "work")


def case_view(case: dict, fields: tuple) -> dict:
    """What is compared of one case."""
    view = {"success": case["success"], "failure": case["failure"], "final_x": case["final_x"],
            "plans": [{"success": p["success"], "footholds": p["footholds"], "executed": p.get("executed"),
                       "apex": p.get("apex")} for p in case["plans"]]}
    if "found-work" in fields:
        for mine, p in zip(view["plans"], case["plans"]):
            if p["success"] or "work" in fields:
                mine.update(ode_calls=p["ode_calls"], nodes_expanded=p["nodes_expanded"])
    return view


def first_difference(a, b, where: str = ""):
    """The path and values of the first place where two JSON values differ, or None."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in a.keys() | b.keys():
            d = first_difference(a.get(k), b.get(k), f"{where}.{k}")
            if d:
                return d
        return None
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return f"{where}: {len(a)} entries vs {len(b)}"
        for i, (u, v) in enumerate(zip(a, b)):
            d = first_difference(u, v, f"{where}[{i}]")
            if d:
                return d
        return None
    return None if a == b else f"{where}: {a!r} vs {b!r}"


def compare(first: dict, second: dict, rename: dict, fields: tuple) -> tuple[list, list]:
    """(rows of per-planner counts, differences) for two results dicts."""
    rows, differences = [], []
    for label, block in first["planners"].items():
        other = rename.get(label, label)
        if other not in second["planners"]:
            continue
        theirs = {c["id"]: c for c in second["planners"][other]["cases"]}
        same = compared = 0
        for case in block["cases"]:
            if case["id"] not in theirs:
                continue
            compared += 1
            d = first_difference(case_view(case, fields), case_view(theirs[case["id"]], fields))
            if d:
                differences.append(f"{label} / {other} {case['id']}{d}")
            else:
                same += 1
        rows.append((label, other, compared, same))
    return rows, differences


def main(argv=None) -> int:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("first", type=cli.input_file, help="results JSON of examples/evaluate.py")
    ap.add_argument("second", type=cli.input_file, help="another results JSON of the same suite")
    ap.add_argument("--rename", action="append", default=[], metavar="OLD=NEW",
                    help="compare the first file's label OLD with the second's NEW (repeatable)")
    ap.add_argument("--fields", choices=FIELDS, default="work",
                    help="outcome: outcomes and footholds only; found-work: also the ODE calls and nodes of every "
                         "planning call that found a plan; work: of every planning call")
    ap.add_argument("--show", type=cli.non_negative_int, default=10, help="differences printed at most")
    args = ap.parse_args(argv)
    pairs = [r.split("=", 1) for r in args.rename]
    if any(len(p) != 2 or not all(p) for p in pairs):
        ap.error(f"--rename takes OLD=NEW, got {args.rename}")
    files = []
    for path in (args.first, args.second):
        try:
            data = read_json(path, "results file")
        except OSError as error:
            ap.error(f"cannot read results file {path}: {error}")
        except ValueError as error:
            ap.error(str(error))
        if not isinstance(data, dict) or not isinstance(data.get("planners"), dict):
            ap.error(f"{path} is not a results file of examples/evaluate.py (no 'planners')")
        files.append(data)
    fields = FIELDS[:FIELDS.index(args.fields) + 1]
    rows, differences = compare(*files, dict(pairs), fields)
    if not rows:
        ap.error("the two files share no planner label (see --rename)")
    for label, other, compared, same in rows:
        name = label if label == other else f"{label} -> {other}"
        print(f"{name:<36} {same:>4} of {compared:>4} cases identical ({', '.join(fields)})")
    for d in differences[:args.show]:
        print("  differs: " + d)
    return cli.FAILED if differences else cli.OK


if __name__ == "__main__":
    sys.exit(main())
