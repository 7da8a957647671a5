"""Plan one suite case with any registered planner and save the plan as a self-contained JSON file.

The planner sees the perception window around the start apex, as in the receding-horizon evaluation's first
planning call; the file holds the whole terrain, so examples/verify_plan.py checks the plan on the real ground.

    python3 examples/make_plan.py --suite suites/step.json --case 7 --planner step --out out/plan.json
    python3 examples/make_plan.py --suite suites/step.json --case 7 --planner trajopt \
        --options '{"seed": "lstm-guided"}' --out out/trajopt-plan.json
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import drakeslip as ds
import planners
from planners.evaluation import make_planners, perceived
from planners.plan_io import save_plan
from planners.presets import PRESETS
from planners.suite import load_suite


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--suite", type=Path, required=True, help="suite file (drakeslip-suite/1 JSON)")
    parser.add_argument("--case", required=True, help="case index (0-based) or case id")
    parser.add_argument("--planner", required=True, help=f"one of {', '.join(planners.available())}, or a preset "
                        f"of settings beyond the paper: {', '.join(PRESETS)}")
    parser.add_argument("--options", default="{}",
                        help='the planner\'s options as a JSON object, e.g. \'{"seed": "lstm-guided"}\' for trajopt')
    parser.add_argument("--out", type=Path, required=True, help="plan file to write (JSON)")
    args = parser.parse_args(argv)
    try:
        options = json.loads(args.options)
    except json.JSONDecodeError as error:
        parser.error(f"--options is not valid JSON ({error}): {args.options!r}")
    if not isinstance(options, dict):
        parser.error(f"--options must be a JSON object of planner options, got {args.options!r}")
    try:
        suite = load_suite(args.suite)
        planner = make_planners({args.planner: options})[args.planner]  # a label: NAME, NAME@VARIANT or a preset
    except (OSError, ValueError) as error:
        parser.error(str(error))
    ids = [c.id for c in suite.cases]
    if args.case in ids:
        case = suite.cases[ids.index(args.case)]
    elif args.case.isdigit() and int(args.case) < len(ids):
        case = suite.cases[int(args.case)]
    else:
        parser.error(f"--case {args.case!r} is neither a case id nor an index below {len(ids)} in {args.suite}")
    params = ds.SlipParams(friction=suite.friction)
    plan = planner.plan(case.apex, perceived(case.terrain, case.apex.x), suite.goal_x, params)
    if not plan.success:
        print(f"{args.planner} on {case.id}: {plan.message}")
        return 1
    save_plan(args.out, plan, case.apex, case.terrain, suite.goal_x, params)
    print(f"{args.planner} on {case.id}: {len(plan.footholds)} footholds to x={plan.footholds[-1]:.3f} "
          f"(target {plan.target_x:g}) in {plan.time_s:.3f} s; wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
