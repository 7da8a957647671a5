"""Planning time side by side: every planner plans every case of the suites, interleaved, in one process; the
mean planning time per label, where it goes (``Plan.timing``), and the ratios the planning core is judged by.

    python3 examples/planning_speed.py --cases 30 --repeats 3

For each case (every k-th of each suite, so --cases spread over it) each label plans from the case's start apex
to the suite's goal --repeats times in turn and the fastest call is kept (the machine's other load slows a call,
never speeds it). Printed per suite and label: success, mean planning time, nodes expanded and step-map calls per
call, planning time per step-map call and the step map's own time per call (from the same calls' accounting), the
breakdown, then each --pairs ratio SLOW/FAST of mean planning times.

Exit status: 0 when the timings ran, 2 for a usage or input error.
"""
from __future__ import annotations

import sys

from drakeslip.jobs import cli

DEFAULT_LABELS = "step,lstm-guided,step@robust,lstm-guided@robust"
DEFAULT_PAIRS = "step:lstm-guided,step@robust:lstm-guided@robust,step@robust:step"
PARTS = ("step_map_s", "controller_s", "model_s", "search_s")


def pair_list(text: str) -> list:
    """``A:B,C:D`` as [(A, B), (C, D)]."""
    pairs = [p.split(":") for p in text.split(",") if p]
    if not pairs or any(len(p) != 2 or not all(p) for p in pairs):
        raise ValueError(f"--pairs takes SLOW:FAST label pairs, comma-separated, got {text!r}")
    return [tuple(p) for p in pairs]


def main(argv=None) -> int:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--suites", type=cli.names, default="suites/ditch.json,suites/step.json",
                    help="suite files, comma-separated")
    ap.add_argument("--planners", type=cli.names, default=DEFAULT_LABELS, help="planner labels, comma-separated")
    ap.add_argument("--pairs", default=DEFAULT_PAIRS, help="SLOW:FAST label pairs whose time ratio is printed")
    ap.add_argument("--cases", type=cli.positive_int, default=30, help="cases per suite, spread over it")
    ap.add_argument("--repeats", type=cli.positive_int, default=3, help="calls per case and label (the fastest kept)")
    args = ap.parse_args(argv)
    from planners.registry import check_label

    try:
        pairs = pair_list(args.pairs)
        for label in (*args.planners, *(x for p in pairs for x in p)):
            check_label(label)
    except ValueError as error:
        ap.error(str(error))
    missing = [x for p in pairs for x in p if x not in args.planners]
    if missing:
        ap.error(f"--pairs names labels not in --planners: {', '.join(missing)}")

    import statistics

    from drakeslip import SlipParams
    from planners.formats.suite import load_suite
    from planners.registry import make_planners

    try:
        suites = [load_suite(path) for path in args.suites]
    except (OSError, ValueError) as error:
        ap.error(str(error))
    planners = make_planners({label: None for label in args.planners})
    for suite in suites:
        params = SlipParams(friction=suite.friction) if suite.hopper is None else suite.hopper.params
        cases = suite.cases[::max(1, len(suite.cases) // args.cases)][:args.cases]
        best = {label: [] for label in planners}
        for case in cases:
            for label, planner in planners.items():
                plans = [planner.plan(case.apex, case.terrain, suite.goal_x, params) for _ in range(args.repeats)]
                best[label].append(min(plans, key=lambda p: p.time_s))
        print(f"suite {suite.name}: {len(cases)} cases, the fastest of {args.repeats} calls each")
        print(f"{'planner':<20} {'success':>8} {'t_plan ms':>10} {'nodes':>7} {'calls':>7} {'us/call':>8} "
              f"{'map us/call':>11} "
              f"{'ratio':>6}   " + " ".join(f"{p[:-2] + ' ms':>14}" for p in PARTS))
        means = {}
        for label, plans in best.items():
            means[label] = statistics.fmean(p.time_s for p in plans)
            calls = sum(p.ode_calls for p in plans)
            timed = [p.timing for p in plans if p.timing]
            parts = {k: statistics.fmean(t[k] for t in timed) if timed else float("nan") for k in PARTS}
            per_call = sum(p.time_s for p in plans) / calls * 1e6 if calls else float("nan")
            map_call = sum(t["step_map_s"] for t in timed) / calls * 1e6 if calls and timed else float("nan")
            nodes = statistics.fmean(p.nodes_expanded for p in plans)
            print(f"{label:<20} {sum(p.success for p in plans):>4}/{len(plans):<3} {1e3 * means[label]:>10.2f} "
                  f"{nodes:>7.1f} {calls / len(plans):>7.0f} {per_call:>8.1f} {map_call:>11.1f} "
                  f"{per_call / map_call:>6.1f}   "
                  + " ".join(f"{1e3 * parts[k]:>14.3f}" for k in PARTS))
        for slow, fast in pairs:
            print(f"  mean t_plan {slow} / {fast} = {means[slow] / means[fast]:.2f}x")
    return cli.OK


if __name__ == "__main__":
    sys.exit(main())
