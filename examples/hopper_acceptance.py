"""Does planning work for any hopper? Hoppers drawn at random from the toolkit's range (and its two corners), a
ditch suite drawn for each, the planners held to the acceptance bars of verification/hopper_acceptance.py:

    python3 examples/hopper_acceptance.py --hoppers 4 --seed 35 --every 3 --backend drake --jobs 2 --out out/acceptance

Per hopper: ``step`` on the ditch suite without noise (>= 95 %), ``step@robust`` under realistic noise (>= 90 %),
``lstm-guided`` without noise (within 5 points of step, fewer ODE calls per plan); ``--families step,mixed`` adds
those families for step and lstm-guided (reported, no bar). Suites are drawn from terrain seed ``--suite-seed`` (a
fresh one: the committed suites use 1000 and 2000). --hopper FILE|DIR checks that hopper alone (a hopper folder's
weights from examples/train_hopper.py are then read) instead of the drawn ones. Results go to OUT/HOPPER-FAMILY.json,
each with its case cache, so a killed run resumes. Prints one table; exit 0 when every bar holds, 1 when one does not,
2 for a usage error, 3 a simulation crashed (one line naming what failed: drakeslip/jobs/cli.py).
"""
from __future__ import annotations

import sys

from drakeslip.jobs import cli
from drakeslip import cli_physics


@cli_physics.reports_crashes
def main(argv=None) -> int:
    ap = cli.ArgumentParser(__doc__)
    cli_physics.add_hopper_argument(ap, default="the drawn hoppers")
    ap.add_argument("--hoppers", type=cli.non_negative_int, default=4, help="random hoppers after the two corners")
    ap.add_argument("--seed", type=cli.non_negative_int, default=35, help="seed of the hopper draws")
    ap.add_argument("--no-corners", action="store_true", help="only the random hoppers")
    ap.add_argument("--suite-seed", type=cli.non_negative_int, default=35000, help="terrain seed of the suites")
    ap.add_argument("--every", type=cli.positive_int, default=3, help="every K-th case of each 150-case suite")
    ap.add_argument("--families", type=cli.names, default=None,
                    help="more terrain families, comma-separated, for step and lstm-guided (e.g. step,mixed)")
    ap.add_argument("--backend", choices=("drake", "fast", "multibody"), default="drake",
                    help="what executes the plans: the Drake SLIP, the fast step map, or each hopper's multibody robot")
    ap.add_argument("--out", type=cli.output_folder, required=True, help="folder of the results JSON files")
    ap.add_argument("--quiet", action="store_true", help="no progress bars")
    cli.add_parallel(ap)
    args = ap.parse_args(argv)
    from drakeslip.terrain import check_families
    try:
        families = check_families(args.families) if args.families else ()
    except ValueError as error:
        ap.error(str(error))
    executor = cli.executor(args)

    from drakeslip.jobs.runner import write_json
    from verification.hopper_acceptance import RUNS, checks, describe, evaluate_hopper, random_hoppers

    hoppers = ([args.hopper] if args.hopper
               else random_hoppers(args.seed, args.hoppers, corners=not args.no_corners))
    ap.check_outputs(args, [("--out", args.out / f"{h.name}-{family}.json{cache}") for h in hoppers
                            for family in ("ditch", *families) for cache in ("", ".cases.jsonl")])
    args.out.mkdir(parents=True, exist_ok=True)
    rows = ["| hopper | family | planner | success % | ODE calls / plan | bar | holds |",
            "|---|---|---|---|---|---|---|"]
    ok = True
    for h in hoppers:
        for family in ("ditch", *[f for f in families if f != "ditch"]):
            labels = list(RUNS) if family == "ditch" else ["step", "lstm-guided"]
            path = args.out / f"{h.name}-{family}.json"
            results = evaluate_hopper(h, family, args.suite_seed, labels, args.every, args.backend, executor,
                                      cache_path=f"{path}.cases.jsonl", progress=not args.quiet)
            write_json(path, results)
            found = checks(results) if family == "ditch" else []
            bars = {label: (bar, passed) for label in labels for what, _, bar, passed in found
                    if what.startswith(f"{label} (")}
            for label, r in results["planners"].items():
                bar, passed = bars.get(label, ("", None))
                rows.append(f"| {h.name}: {describe(h)} | {family} | {label} | {100 * r['success_rate']:.1f} | "
                            f"{r['ode_calls_mean']:.0f} | {bar} | {'' if passed is None else passed} |")
            for what, value, bar, passed in found:
                ok &= passed
                if what.startswith("lstm-guided "):
                    rows.append(f"| {h.name} | ditch | {what} | {value:.2f} | | {bar} | {passed} |")
    print("\n".join(rows))
    return cli.OK if ok else cli.FAILED


if __name__ == "__main__":
    sys.exit(main())
