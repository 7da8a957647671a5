"""Receding-horizon evaluation of planners on a suite (the paper's Tables II/III).

    python examples/evaluate.py --suite suites/ditch.json --planners heuristic,angle,step --jobs 2 --out out/ditch.json

Each planning call sees the 8 m / 3 m perception window; the first 3 footholds are executed by the
controller on the Drake simulator, then it replans. Finished cases are cached in OUT.cases.jsonl, so a
killed run continues where it stopped (--no-resume starts over). Two settings of one planner run side by side
as NAME@VARIANT, with their options keyed by that label:

    python examples/evaluate.py --suite suites/ditch.json --planners step,lstm-guided,lstm-guided@lazy \
        --options '{"lstm-guided@lazy": {"lazy": true}}' --backend fast --jobs 2 --out out/lazy.json

Planning on the Drake model itself (each candidate hop simulated on Drake, about 0.1 s a hop) is slow, so take
a spread-out sample of the cases:

    python examples/evaluate.py --suite suites/ditch.json --every 13 --cases 10 --planners step,lstm-guided \
        --options '{"step": {"step_map": "drake", "max_time_s": 600},
                    "lstm-guided": {"step_map": "drake", "max_time_s": 600}}' --baseline step --out out/drake.json
"""
from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from planners import available, planner_name
from planners.registry import label_options
from planners.evaluation import EvalConfig, evaluate, make_planners, ratios, table, write_json
from planners.suite import load_suite


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--suite", required=True, help="suite JSON file (format drakeslip-suite/1)")
    ap.add_argument("--planners", default="heuristic,angle,step",
                    help=f"comma-separated, of {available()}, each optionally NAME@VARIANT")
    ap.add_argument("--cases", type=int, default=None, help="only the first N cases (after --every)")
    ap.add_argument("--every", type=int, default=1,
                    help="take every K-th case (suites list 10 starts per terrain: K = 7 or 13 spreads a few "
                         "cases over the terrains and starts)")
    ap.add_argument("--out", required=True, help="results JSON (written atomically)")
    ap.add_argument("--jobs", type=int, default=1, help="worker processes")
    ap.add_argument("--options", default="{}",
                    help='planner options as JSON, e.g. \'{"angle": {"branching": 15, "seed": 1}}\'')
    ap.add_argument("--controller", default=None, help="controller weights (default: the committed ones)")
    ap.add_argument("--executed", type=int, default=EvalConfig.executed_per_plan, help="footholds per plan")
    ap.add_argument("--backend", default="drake", choices=("drake", "fast"),
                    help="simulator that executes the plans (drake: the protocol; fast: quick diagnosis)")
    ap.add_argument("--mlp-only", action="store_true",
                    help="ablation: the controller without its Newton polish (the paper's MLP controller)")
    ap.add_argument("--no-resume", action="store_true", help="ignore and replace the case cache")
    ap.add_argument("--baseline", default=None,
                    help="also print this planner's ODE calls and planning time over each other planner's")
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    args = ap.parse_args(argv)
    print("reproduce with: python " + " ".join(shlex.quote(a) for a in [sys.argv[0]] + (argv or sys.argv[1:])))

    if args.every < 1 or (args.cases is not None and args.cases < 1):
        ap.error(f"--every and --cases must be positive, got --every {args.every} --cases {args.cases}")
    if args.jobs < 1:
        ap.error(f"--jobs must be at least 1, got {args.jobs}")
    names = [n for n in args.planners.split(",") if n]
    unknown = [n for n in names if planner_name(n) not in available()]
    if unknown:
        ap.error(f"unknown planner(s) {unknown}; known planners: {', '.join(available())}")
    if args.baseline is not None and args.baseline not in names:
        ap.error(f"--baseline {args.baseline!r} is not among --planners {names}")
    try:
        options = label_options(args.options, names)
    except ValueError as error:
        ap.error(str(error))
    try:  # a bad option is refused here, by label, not in a worker's traceback
        make_planners(options)
    except ValueError as error:
        ap.error(f"--{error}")  # "--options for LABEL: ..."
    try:
        suite = load_suite(args.suite)
    except (OSError, ValueError) as error:  # a missing or malformed suite file
        ap.error(str(error))
    cache = Path(args.out + ".cases.jsonl")
    if args.no_resume and cache.exists():
        cache.unlink()
    results = evaluate(suite, {n: options.get(n, {}) for n in names}, n_cases=args.cases, every=args.every,
                       jobs=args.jobs, cache_path=cache, controller_path=args.controller,
                       config=EvalConfig(executed_per_plan=args.executed, backend=args.backend,
                                         refine=not args.mlp_only), progress=not args.quiet)
    write_json(results, args.out)
    print(table(results))
    if args.baseline:
        print(ratios(results, args.baseline))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
