r"""Are each planner's plans what they say? The first plan of every case, checked on Drake as written.

    python3 examples/certify_plans.py --suite suites/step.json --every 15 --jobs 2 --out out/certify-step.json

For every planner label and every chosen case, the plan from the case's start apex (on its perception window) is
saved as a plan file would save it and checked by verification/plan_check.py: CERTIFIED when the Drake run
completes every hop with no failure, touches down within --tolerance of every foothold, reaches every predicted
apex within --tolerance and reaches the plan's target; else the first mismatch. Finished cases are kept in
OUT.cases.jsonl (a killed run resumes; a record is reused only by the code, options and weights that made it). The
plans are made for the suite's hopper; --hopper (a hopper file or folder) must be that one, and a folder's weights
are then read; the results record the hopper.

Exit status: 0 when the checks ran (whatever their verdicts; a plan whose check stopped before a verdict is "simulation
stopped"), 2 for a usage or input error, 3 a simulation crashed (one line naming what failed: drakeslip/jobs/cli.py).
"""
from __future__ import annotations

import hashlib
import json
import sys
from collections import Counter
from dataclasses import asdict

from drakeslip.jobs import cli
from drakeslip import cli_physics
from planners.registry import check_label, labels, planner_name
from verification.plan_check_options import MODES, TOLERANCE


def arguments() -> cli.ArgumentParser:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--suite", type=cli.input_file, required=True, help="suite file (format drakeslip-suite/1)")
    searched = [label for label in labels() if planner_name(label) != "trajopt"]   # trajopt: trajopt_warmstart.py
    ap.add_argument("--planners", type=cli.names, default=",".join(searched), help="planner labels, comma-separated")
    ap.add_argument("--cases", type=cli.positive_int, default=10, help="the first N cases (after --every)")
    ap.add_argument("--every", type=cli.positive_int, default=15, help="every K-th case of the suite")
    cli_physics.add_hopper_argument(ap, default="the suite's")
    ap.add_argument("--mode", choices=MODES, default="auto", help="how the plans are executed (see verify_plan.py)")
    ap.add_argument("--tolerance", type=cli.positive, default=TOLERANCE, help="foothold and apex tolerance [m, m/s]")
    ap.add_argument("--out", type=cli.output_file(".json", beside=(".cases.jsonl",)), required=True,
                    help="results JSON")
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    cli.add_parallel(ap)
    return ap


def checked_inputs(ap: cli.ArgumentParser, args):
    """(suite, hopper, planner specs, worker setup), or one line and exit status 2 for a bad suite, hopper, label
    or weights file."""
    from drakeslip.jobs.executors import prepare
    from planners.formats.suite import load_suite
    from planners.formats.suite_draw import hopper_for_suite
    from planners.registry import hopper_specs
    from verification import certify

    try:
        suite = load_suite(args.suite)
        hopper = hopper_for_suite(suite, args.hopper)
        specs = hopper_specs({check_label(label): None for label in args.planners}, hopper)
        setup = (certify.prepare, (specs,))
        prepare(setup)
    except (OSError, ValueError) as error:
        ap.error(str(error))
    return suite, hopper, specs, setup


def certified(args, suite, hopper, specs, setup, executor, code: str) -> list[dict]:
    """The record of each (planner, case), planners first, checked (or read from OUT.cases.jsonl, where the code
    ``code`` wrote them)."""
    from tqdm import tqdm

    from drakeslip.jobs.runner import JsonLinesStore, run
    from planners.formats.suite import terrain_record
    from verification import certify
    from verification.evaluation import weights_files

    # the paper's hopper is left out of the task and its key: None is the worker's default hopper
    body = None if suite.hopper is None else asdict(hopper.params)
    cases = list(suite.cases[::args.every])[:args.cases]
    # a cached record is used only for the same code (the store's stamp), planner options and weights files
    setups = {label: [label, specs[label], weights_files(label, specs[label])] for label in specs}
    key = lambda label, c: hashlib.sha256(json.dumps(
        [*setups[label], c.id, c.terrain.to_dict(), list(c.apex), suite.goal_x, suite.friction, args.mode,
         args.tolerance, *([body] if body else [])], sort_keys=True, default=str).encode()).hexdigest()[:20]
    tasks = [(key(label, c), (label, {"id": c.id, "terrain": terrain_record(c.terrain), "apex": c.apex._asdict()},
                               suite.goal_x, suite.friction, args.mode, args.tolerance, body))
             for label in specs for c in cases]
    records = {}
    with tqdm(total=len(tasks), disable=args.quiet, unit="plan", desc=suite.name) as bar:
        store = JsonLinesStore(str(args.out) + ".cases.jsonl", certify.check_record, code)
        for k, record in run(certify.certify_case, tasks, store, executor, setup):
            records[k] = record
            bar.update()
    return [records[k] for k, _ in tasks]


def report(specs, ordered: list[dict]) -> None:
    """A row of verdicts per planner, then each plan that is not certified."""
    print(f"{'planner':<20} {'certified':>9} {'counterexample':>14} {'no plan':>7} {'malformed':>9}  first mismatches")
    for label in specs:
        mine = [r for r in ordered if r["label"] == label]
        count = Counter(r["verdict"] for r in mine)
        kinds = Counter(r["kind"] if r["kind"] != "failure" else r["reason"].split()[0] for r in mine
                        if r["verdict"] == "counterexample")
        mismatches = ", ".join(f"{k} {v}" for k, v in kinds.items()) or "-"
        print(f"{label:<20} {count['certified']:>4} / {len(mine):<2} {count['counterexample']:>14} "
              f"{count['no plan']:>7} {count['malformed']:>9}  {mismatches}")
    for r in ordered:
        if r["verdict"] != "certified":
            print(f"  {r['label']} {r['id']}: {r['verdict']}: {r['reason']}")


@cli_physics.reports_crashes
def main(argv=None) -> int:
    ap = arguments()
    args = ap.parse_args(argv)
    executor = cli.executor(args)
    suite, hopper, specs, setup = checked_inputs(ap, args)
    cli.announce(argv)

    from drakeslip.jobs.runner import write_json
    from verification.provenance import code_version, provenance

    code = code_version()   # the cached records are this code's, and the results file names it
    ordered = certified(args, suite, hopper, specs, setup, executor, code)

    write_json(args.out, {"suite": suite.name, "hopper": hopper.to_record(), "mode": args.mode,
                          "tolerance": args.tolerance, "plans": ordered, "provenance": provenance(code)})
    report(specs, ordered)
    print(f"wrote {args.out}")
    return cli.OK


if __name__ == "__main__":
    sys.exit(main())
