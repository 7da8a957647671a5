"""The model-checking oracle on a suite: is each case traversable at all, and what is the suite's ceiling?

    python3 examples/model_check.py --suite suites/ditch.json --cases 150 --out out/oracle-ditch.json
    python3 examples/model_check.py --suite suites/step.json --cases 30 --seed 0 --out out/oracle-step.json

For each case the oracle searches the apex states reachable over a grid of leg angles (0.5 deg, then 0.25 deg
to confirm a "not-traversable"), merging apexes within 1 cm / 1 cm/s, with the whole terrain known, and
executes any witness on Drake (see verification/model_check.py for what the verdicts mean exactly). Each
finished case is appended to OUT.cases.jsonl, so a killed run continues where it stopped (--no-resume starts
over); a cached "unknown" is rerun when the budget is larger than the one it had. --jobs N checks N cases at a
time in separate processes (--executor ray: on a Ray cluster).

Exit status: 0 done, 1 a planner crossed a case the oracle calls not traversable (--against), 2 a usage error.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from drakeslip.jobs import cli
from verification.model_check import DEFAULT_BUDGET


def main(argv=None) -> int:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--suite", type=cli.input_file, required=True, help="suite JSON file (format drakeslip-suite/1)")
    ap.add_argument("--out", type=cli.output_file(".json"), required=True, help="results JSON (written atomically)")
    ap.add_argument("--cases", type=cli.positive_int, default=None,
                    help="only N cases: the first N, or N at random with --seed")
    ap.add_argument("--seed", type=cli.non_negative_int, default=None, help="draw the --cases at random with this seed")
    ap.add_argument("--ids", type=cli.names, default=None, help="comma-separated case ids (instead of --cases)")
    ap.add_argument("--budget", type=cli.positive_int, default=DEFAULT_BUDGET.max_nodes, help="node expansions per case, all passes")
    ap.add_argument("--seconds", type=cli.positive, default=DEFAULT_BUDGET.max_time_s, help="search seconds per case")
    ap.add_argument("--no-refine", action="store_true",
                    help="call a case not traversable after the 0.5 deg pass alone (no 0.25 deg confirmation)")
    ap.add_argument("--no-drake-check", action="store_true",
                    help="accept witnesses on the fast step map without executing them on Drake (diagnosis only)")
    ap.add_argument("--against", type=cli.names, default=None,
                    help="comma-separated results JSON files of examples/evaluate.py on the same suite: report "
                         "the cases a planner crossed that the oracle calls not traversable (exit 1 if any)")
    ap.add_argument("--no-resume", action="store_true", help="ignore and replace the case cache")
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    cli.add_parallel(ap)
    args = ap.parse_args(argv)
    if args.ids and (args.cases or args.seed is not None):
        ap.error("--ids names the cases; it does not go with --cases or --seed")
    executor = cli.executor(args)

    from drakeslip.jobs.runner import remove, write_json
    from planners.base import Budget
    from planners.formats.suite import load_suite
    from verification.model_check import COARSE, LEVELS, NOT_TRAVERSABLE, UNKNOWN
    from verification.model_check_suite import check_suite, cross_check, select_cases

    try:
        suite = load_suite(args.suite)
        cases = select_cases(suite, args.cases, args.seed, args.ids)
        against = [json.loads(Path(f).read_text()) for f in args.against] if args.against else []
        if not all(isinstance(e, dict) and isinstance(e.get("planners"), dict) for e in against):
            raise ValueError(f"--against {args.against}: not a results file of examples/evaluate.py (no 'planners')")
    except (ValueError, OSError) as exc:
        ap.error(str(exc))
    cli.announce(argv)
    cache = str(args.out) + ".cases.jsonl"
    if args.no_resume:
        remove(cache)
    results = check_suite(suite, cases, cache, Budget(args.budget, max_time_s=args.seconds),
                          levels=(COARSE,) if args.no_refine else LEVELS, drake_check=not args.no_drake_check,
                          progress=not args.quiet, executor=executor)
    write_json(args.out, results)

    s = results["summary"]
    for r in results["cases"]:
        if r["verdict"] in (NOT_TRAVERSABLE, UNKNOWN):
            stops = ", ".join(f"{p['angle_deg']:g} deg: {p['stop']} after {p['nodes']} nodes" for p in r["passes"])
            print(f"  {r['id']:<24} {r['verdict']:<16} {r['time_s']:7.1f} s  ({stops})")
    times = sorted(r["time_s"] for r in results["cases"])
    print(f"{suite.name}: {s['cases']} cases: {s['traversable']} traversable, {s['not_traversable']} not traversable, "
          f"{s['unknown']} unknown; decided {100 * s['decided_rate']:.1f} %, ceiling {100 * s['ceiling']:.1f} %"
          + (f" (at most {100 * s['ceiling_upper']:.1f} %)" if s["unknown"] else ""))
    print(f"time per case: median {s['time_s_median']:.2f} s, mean {sum(times) / len(times):.2f} s, "
          f"max {times[-1]:.1f} s")
    print(f"wrote {args.out}")
    contradicted = 0
    for path, evaluation in zip(args.against or [], against):
        for name, c in cross_check(results, evaluation).items():
            contradicted += len(c["contradicted"])
            missed = " ".join(c["missed"][:6]) + (" ..." if len(c["missed"]) > 6 else "")
            print(f"soundness vs {name} ({path}): crossed {c['crossed']} of {c['compared']}, of which the oracle "
                  f"calls not traversable {len(c['contradicted'])} {' '.join(c['contradicted'])}; failed where "
                  f"the oracle found a witness: {len(c['missed'])} {missed}")
    return cli.FAILED if contradicted else cli.OK


if __name__ == "__main__":
    sys.exit(main())
