"""Planning time side by side: every planner plans every case of the suites, interleaved, in one process; the
mean and median planning time per label, where it goes (``Plan.timing``), and the ratios the planning core is
judged by.

    python3 examples/planning_speed.py --cases 30 --repeats 3
    python3 examples/planning_speed.py --suites out/maps/stones-58000.json --planners step,lstm-guided \
        --pairs step:lstm-guided

A suite is a profile suite or a height-map suite (``make_suites.py --families gaps,...``): on a map each call plans
from the case's start apex over the perception window (8 m ahead) toward the case's goal (x, y). For each case
(every k-th of each suite, so --cases spread over it) each label plans --repeats times in turn and the fastest call
is kept (the machine's other load slows a call, never speeds it), after one untimed call each that loads the
compiled code. Printed per suite and label: success, mean and median planning time, nodes expanded and step-map
calls per call, planning time per step-map call and the step map's own time per call (from the same calls'
accounting), the breakdown, then for each --pairs SLOW:FAST the ratios of mean planning time and of step-map calls,
and the success of each; then the same ratios over the calls both found a plan (a call that finds none spends a
planner's whole budget, whatever guides it).

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
    ap.add_argument("--options", default="{}",
                    help='planner options as JSON keyed by label, e.g. \'{"step@10x": {"max_nodes": 10000}}\'')
    args = ap.parse_args(argv)
    from planners.registry import check_label, label_options

    try:
        pairs = pair_list(args.pairs)
        for label in (*args.planners, *(x for p in pairs for x in p)):
            check_label(label)
        options = label_options(args.options, args.planners)
    except ValueError as error:
        ap.error(str(error))
    missing = [x for p in pairs for x in p if x not in args.planners]
    if missing:
        ap.error(f"--pairs names labels not in --planners: {', '.join(missing)}")

    from planners.formats.suite_draw import hopper_for_suite
    from planners.registry import hopper_specs, make_planners
    from verification.evaluation import check_map_planners

    try:
        suites = [suite_of(path) for path in args.suites]
        runs = [(suite, make_planners(hopper_specs({label: options.get(label) for label in args.planners},
                                                   hopper_for_suite(suite)))) for suite in suites]
        for suite, planners in runs:
            if is_map(suite):
                check_map_planners(planners)
    except (OSError, ValueError) as error:
        ap.error(str(error))
    for suite, planners in runs:
        params = hopper_for_suite(suite).params.with_friction(suite.friction)
        cases = suite.cases[::max(1, len(suite.cases) // args.cases)][:args.cases]
        best = {label: [] for label in planners}
        for label, planner in planners.items():   # untimed: the first call loads the compiled code
            planner.plan(cases[0].apex, cases[0].terrain, cases[0].goal if is_map(suite) else suite.goal_x, params)
        for case in cases:
            goal = case.goal if is_map(suite) else suite.goal_x
            for label, planner in planners.items():
                plans = [planner.plan(case.apex, case.terrain, goal, params) for _ in range(args.repeats)]
                best[label].append(min(plans, key=lambda p: p.time_s))
        print(f"suite {suite.name}: {len(cases)} cases, the fastest of {args.repeats} calls each")
        report(best, pairs)
    return cli.OK


def suite_of(path):
    """The profile or height-map suite in ``path`` (by its format)."""
    from drakeslip.jobs.files import read_json
    from planners.formats.map_suite import is_map_suite, load_map_suite
    from planners.formats.suite import load_suite

    return load_map_suite(path) if is_map_suite(read_json(path, "suite file")) else load_suite(path)


def is_map(suite) -> bool:
    from planners.formats.map_suite import MapSuite

    return isinstance(suite, MapSuite)


def report(best: dict, pairs: list) -> None:
    """The table of each label's fastest calls (module doc) and the --pairs ratios."""
    import statistics

    print(f"{'planner':<20} {'success':>8} {'t_plan ms':>10} {'median ms':>10} {'nodes':>7} {'calls':>7} "
          f"{'us/call':>8} {'map us/call':>11} {'ratio':>6}   " + " ".join(f"{p[:-2] + ' ms':>14}" for p in PARTS))
    means, calls = {}, {}
    for label, plans in best.items():
        means[label] = statistics.fmean(p.time_s for p in plans)
        calls[label] = sum(p.ode_calls for p in plans)
        timed = [p.timing for p in plans if p.timing]
        parts = {k: statistics.fmean(t[k] for t in timed) if timed else float("nan") for k in PARTS}
        per_call = sum(p.time_s for p in plans) / calls[label] * 1e6 if calls[label] else float("nan")
        map_call = (sum(t["step_map_s"] for t in timed) / calls[label] * 1e6 if calls[label] and timed
                    else float("nan"))
        nodes = statistics.fmean(p.nodes_expanded for p in plans)
        median = statistics.median(p.time_s for p in plans)
        print(f"{label:<20} {sum(p.success for p in plans):>4}/{len(plans):<3} {1e3 * means[label]:>10.2f} "
              f"{1e3 * median:>10.2f} {nodes:>7.1f} {calls[label] / len(plans):>7.0f} {per_call:>8.1f} "
              f"{map_call:>11.1f} {per_call / map_call:>6.1f}   " + " ".join(f"{1e3 * parts[k]:>14.3f}" for k in PARTS))
    for slow, fast in pairs:
        won = {label: sum(p.success for p in best[label]) for label in (slow, fast)}
        print(f"  mean t_plan {slow} / {fast} = {means[slow] / means[fast]:.2f}x; step-map calls "
              f"{calls[slow] / max(calls[fast], 1):.2f}x; success {won[slow]} and {won[fast]} of {len(best[slow])}")
        both = [(a, b) for a, b in zip(best[slow], best[fast]) if a.success and b.success]
        if both:   # a call neither finishes spends each planner's whole budget: apart, what the model saves
            time_ratio = sum(a.time_s for a, _ in both) / sum(b.time_s for _, b in both)
            call_ratio = sum(a.ode_calls for a, _ in both) / max(sum(b.ode_calls for _, b in both), 1)
            print(f"    over the {len(both)} calls both found a plan: mean t_plan {time_ratio:.2f}x; step-map calls "
                  f"{call_ratio:.2f}x")

if __name__ == "__main__":
    sys.exit(main())
