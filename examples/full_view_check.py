"""For every case a search planner failed in an evaluation: does a generous search that sees the whole
terrain (no perception window, 40 angle samples or the Step-space grid, 20 s) find a footstep sequence from
the initial apex to the goal? A crude ceiling check on the fast step map: "no" is evidence, not proof, that a
case cannot be crossed.

    python examples/full_view_check.py --results out/results-step.json --suite suites/step.json
"""
from __future__ import annotations

import argparse
import shlex
import sys

from drakeslip import SlipParams
from drakeslip.files import read_json
from planners import make
from planners.suite import load_suite


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--results", required=True, help="results JSON written by examples/evaluate.py")
    ap.add_argument("--suite", required=True, help="the suite it was run on")
    ap.add_argument("--planners", default="angle,step", help="whose failures to check")
    ap.add_argument("--seconds", type=float, default=20.0, help="time budget of each full-view search")
    args = ap.parse_args(argv)
    print("reproduce with: python " + " ".join(shlex.quote(a) for a in [sys.argv[0]] + (argv or sys.argv[1:])))
    try:
        results, suite = read_json(args.results, "results file"), load_suite(args.suite)
    except (OSError, ValueError) as error:  # a missing or malformed file
        ap.error(str(error))
    cases = {c.id: c for c in suite.cases}
    names = args.planners.split(",")
    failed = {n: {c["id"] for c in results["planners"][n]["cases"] if not c["success"]} for n in names}
    params = SlipParams(friction=suite.friction)
    full_view = [make("angle", branching=40, fallback=(), max_nodes=10**6, max_time_s=args.seconds, horizon=1e3),
                 make("step", max_nodes=10**6, max_time_s=args.seconds, horizon=1e3)]
    solvable = {cid: any(p.plan(cases[cid].apex, cases[cid].terrain, suite.goal_x, params).success for p in full_view)
                for cid in sorted(set().union(*failed.values()))}
    for n in names:
        print(f"{n}: failed {len(failed[n])} of {len(results['planners'][n]['cases'])}; a full-view search finds a "
              f"plan for {sum(solvable[c] for c in failed[n])} of them")
    print("no full-view plan found:", " ".join(c for c, ok in solvable.items() if not ok) or "none")


if __name__ == "__main__":
    main()
