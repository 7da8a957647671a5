"""The model-checking oracle on a suite: is each case traversable at all, and what is the suite's ceiling?

    python3 examples/model_check.py --suite suites/ditch.json --cases 150 --out out/oracle-ditch.json
    python3 examples/model_check.py --suite suites/step.json --cases 30 --seed 0 --out out/oracle-step.json

Each case gets one verdict (verification/model_check.py has the details), with a one-line statement of what it
rests on:
  traversable              a witness: leg angles from the grid that reach the goal when executed on Drake.
  proved-not-traversable   the energy argument (verification/energy_bound.py) shows no run of the model reaches
                           the goal, for any leg angles: e.g. every step ahead that must be landed on lies above
                           the landing ceiling H - L0 cos(atan mu) and none can be flown over. No search is run.
  not-traversable          no plan over the leg-angle grid at the resolution it states ("holds_at"): the
                           0.5 deg pass (apexes merged within 1 cm x 1 cm/s) exhausted the apexes reachable on the
                           fast step map (none slower than 0.1 m/s), and then the 0.25 deg pass (5 mm x 1 cm/s) too,
                           or it ran out of budget first ("unconfirmed"; with --confirm such a case is unknown).
  unknown                  the seconds or nodes ran out (a pass that had exhausted is named), or Drake rejected
                           the witnesses. The ceiling lies between "ceiling" and "at most" then.
Each finished case is appended to OUT.cases.jsonl, so a killed run continues where it stopped (--no-resume
starts over); a cached verdict is reused only by the same code, and a cached "unknown" is rerun when the budget is
larger than the one it had. --jobs N checks N cases
at a time in separate processes (--executor ray: on a Ray cluster).

Exit status: 0 done, 1 a planner crossed a case the oracle proved not traversable (--against), 2 a usage error,
3 a simulation crashed (one line naming what failed: drakeslip/jobs/cli.py).
"""
from __future__ import annotations

import sys

from drakeslip.jobs import cli
from drakeslip import cli_physics
from drakeslip.jobs.files import read_json
from planners.base import MAX_NODES
from verification.model_check import DEFAULT_BUDGET


def arguments() -> cli.ArgumentParser:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--suite", type=cli.input_file, required=True, help="suite JSON file (format drakeslip-suite/1)")
    ap.add_argument("--out", type=cli.output_file(".json", beside=(".cases.jsonl",)), required=True,
                    help="results JSON (written atomically)")
    ap.add_argument("--cases", type=cli.positive_int, default=None,
                    help="only N cases: the first N, or N at random with --seed")
    ap.add_argument("--seed", type=cli.non_negative_int, default=None, help="draw the --cases at random with this seed")
    ap.add_argument("--ids", type=cli.names, default=None, help="comma-separated case ids (instead of --cases)")
    ap.add_argument("--budget", type=cli.integer(1, MAX_NODES), default=DEFAULT_BUDGET.max_nodes,
                    help="node expansions per case, all passes")
    ap.add_argument("--seconds", type=cli.positive, default=DEFAULT_BUDGET.max_time_s, help="search seconds per case")
    ap.add_argument("--no-refine", action="store_true",
                    help="call a case not traversable after the 0.5 deg pass alone (no 0.25 deg confirmation)")
    ap.add_argument("--confirm", action="store_true",
                    help="call a case not traversable only when the 0.25 deg pass exhausts too (else unknown)")
    ap.add_argument("--parallel-steps", action="store_true",
                    help="spread each case's hops over all cores (only with --jobs 1; the same verdicts, sooner)")
    ap.add_argument("--no-energy", action="store_true",
                    help="search without the energy argument: no proved verdicts, no pruning (diagnosis only)")
    ap.add_argument("--no-drake-check", action="store_true",
                    help="accept witnesses on the fast step map without executing them on Drake (diagnosis only)")
    ap.add_argument("--against", type=cli.names, default=None,
                    help="comma-separated results JSON files of examples/evaluate.py on the same suite: report "
                         "the cases a planner crossed that the oracle proved not traversable (exit 1 if any) or "
                         "found no plan for on its grid, and those it failed that the oracle crossed")
    cli_physics.add_hopper_argument(ap, default="the suite's; another is refused in one line")
    ap.add_argument("--no-resume", action="store_true", help="ignore and replace the case cache")
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    cli.add_parallel(ap)
    return ap


def check_flags(ap: cli.ArgumentParser, args) -> None:
    """One line and exit status 2 for flags that do not go together."""
    if args.ids and (args.cases or args.seed is not None):
        ap.error("--ids names the cases; it does not go with --cases or --seed")
    if args.parallel_steps and (args.jobs > 1 or args.executor != "local"):
        ap.error("--parallel-steps uses every core for one case: it goes with --jobs 1 and the local executor")


def checked_inputs(ap: cli.ArgumentParser, args):
    """(the suite, its cases to check, the --against results), or one line and exit status 2 for a bad suite, another
    hopper, case ids not in the suite, or an --against file that is not a results file."""
    from planners.formats.suite import load_suite
    from planners.formats.suite_draw import hopper_for_suite
    from verification.model_check_suite import select_cases

    try:
        suite = load_suite(args.suite)
        hopper_for_suite(suite, args.hopper)
        cases = select_cases(suite, args.cases, args.seed, args.ids)
        against = [read_json(f, "--against file") for f in args.against] if args.against else []
        if not all(isinstance(e, dict) and isinstance(e.get("planners"), dict) for e in against):
            raise ValueError(f"--against {args.against}: not a results file of examples/evaluate.py (no 'planners')")
    except (ValueError, OSError) as exc:
        ap.error(str(exc))
    return suite, cases, against


def report(suite, results: dict) -> None:
    """Each case not traversable, then the suite's summary."""
    from verification.model_check import TRAVERSABLE

    s = results["summary"]
    for r in results["cases"]:
        if r["verdict"] != TRAVERSABLE:
            print(f"  {r['id']:<24} {r['verdict']:<22} {r['time_s']:7.1f} s  {r['statement']}")
    times = sorted(r["time_s"] for r in results["cases"])
    print(f"{suite.name}: {s['cases']} cases: {s['traversable']} traversable, {s['not_traversable']} not traversable "
          f"({s['proved_not_traversable']} proved, {s['not_traversable_grid']} at grid resolution), {s['unknown']} "
          f"unknown; decided {100 * s['decided_rate']:.1f} %, ceiling {100 * s['ceiling']:.1f} %"
          + (f" (at most {100 * s['ceiling_upper']:.1f} %)" if s["unknown"] else ""))
    for text, k in s["grid_holds_at"].items():
        print(f"  not traversable at grid resolution {text}: {k}")
    if s["proved_not_traversable"]:
        print(f"  proved not traversable (energy: no leg angles at all): {s['proved_not_traversable']}")
    if s["unknown"]:
        print("  unknown: " + ", ".join(f"{k} ({why})" for why, k in s["unknown_why"].items()))
    print(f"time per case: median {s['time_s_median']:.2f} s, mean {sum(times) / len(times):.2f} s, "
          f"max {times[-1]:.1f} s")


def contradictions(results: dict, paths, against: list) -> int:
    """Print each --against planner's results beside the oracle's verdicts; the count of its crossings of cases the
    oracle proved not traversable."""
    from verification.model_check_suite import cross_check

    contradicted = 0
    for path, evaluation in zip(paths or [], against):
        for name, c in cross_check(results, evaluation).items():
            contradicted += len(c["contradicted"])
            missed = " ".join(c["missed"][:6]) + (" ..." if len(c["missed"]) > 6 else "")
            print(f"soundness vs {name} ({path}): crossed {c['crossed']} of {c['compared']}, of which the oracle "
                  f"proved not traversable {len(c['contradicted'])} {' '.join(c['contradicted'])}, found no plan "
                  f"on its grid {len(c['off_grid'])} {' '.join(c['off_grid'])}; failed where the oracle found a "
                  f"witness: {len(c['missed'])} {missed}")
    return contradicted


@cli_physics.reports_crashes
def main(argv=None) -> int:
    ap = arguments()
    args = ap.parse_args(argv)
    check_flags(ap, args)
    executor = cli.executor(args)
    suite, cases, against = checked_inputs(ap, args)
    cli.announce(argv)

    from drakeslip.jobs.runner import remove, write_json
    from planners.base import Budget
    from verification.model_check import COARSE, LEVELS
    from verification.model_check_suite import check_suite
    from verification.provenance import code_version, provenance

    cache = str(args.out) + ".cases.jsonl"
    if args.no_resume:
        remove(cache)
    code = code_version()   # the cached verdicts are this code's, and the results file names it
    results = check_suite(suite, cases, cache, Budget(args.budget, max_time_s=args.seconds),
                          levels=(COARSE,) if args.no_refine else LEVELS, drake_check=not args.no_drake_check,
                          progress=not args.quiet, executor=executor, energy=not args.no_energy,
                          confirm=args.confirm, parallel=args.parallel_steps, code=code)
    results["budget"] = {"max_nodes": args.budget, "max_time_s": args.seconds}  # the config leaves it out
    results["provenance"] = provenance(code)
    write_json(args.out, results)
    report(suite, results)
    print(f"wrote {args.out}")
    return cli.FAILED if contradictions(results, args.against, against) else cli.OK


if __name__ == "__main__":
    sys.exit(main())
