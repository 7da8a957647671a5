"""Fit the SLIP template to the multibody robot and write it as a hopper file the planners plan for.

    python3 examples/fit_template.py --cases 6 --out drakeslip/multibody/template.json
    python3 examples/fit_template.py --robot spatial --jobs 2 --out out/spatial_template.json

Runs --cases cases of each suite (every --every-th) in the robot's closed loop with step@robust, records every
hop (apex, foothold -> next apex), fits the template's leg length and stiffness to the robot's apex-to-apex map
(drakeslip/multibody/fit.py), prints the per-hop prediction errors (median and 90th percentile in x, z, xdot) of
the paper's template, of the fitted one and of the one the planners use now ("current", when there is one), on
the hops fitted and on held-out hops (the next cases), and over all of them by the hop's speed change
("by_speed_change", m/s bands), and writes the fitted template (drakeslip-hopper/1; the
multibody backend's planners plan for the one at the default --out).

With --robot spatial the robot is the spatial one (drakeslip/spatial/multibody) on height maps: --suites are map
suites (default: the five map families drawn from --seed, 150 cases each), whose cases run in the robot's map loop
with step replanning at every apex (--jobs at a time); the fit (drakeslip/spatial/multibody/fit.py) is written as
the factors of the hopper's leg length and stiffness (they hold for any hopper's robot), with the errors (median
and 90th percentile in x, y, z, position [m] and horizontal velocity [m/s]) of the hopper's own SLIP and of the
fitted one on the held-out hops. Exit status: 0 written, 1 no hops recorded, 2 bad input, 3 a simulation crashed
(one line naming what failed: drakeslip/jobs/cli.py).
"""
from __future__ import annotations

import json
import sys

from drakeslip.jobs import cli
from drakeslip import cli_physics

OK, FAILED = 0, 1


def collect_hops(cases, goal_x: float, params) -> list:
    """Every completed hop of each case run in the robot's closed loop (noiseless) with step@robust."""
    from drakeslip import ApexState
    from drakeslip.multibody.fit import hops_from_log
    from planners.drake_system import run_closed_loop

    hops = []
    for case in cases:
        result = run_closed_loop("step@robust", case, goal_x, params, trajectory=True)
        hops += hops_from_log(result["log"], ApexState(*map(float, case.apex)), case.terrain)
    return hops


def parser() -> cli.ArgumentParser:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--robot", choices=("planar", "spatial"), default="planar",
                    help="the planar robot on profiles, or the spatial robot on height maps")
    ap.add_argument("--suites", default=None,
                    help="suites whose cases to run (default: suites/ditch.json,suites/step.json; with --robot "
                         "spatial, the map families drawn from --seed)")
    ap.add_argument("--seed", type=cli.integer(0), default=59300, help="--robot spatial: the drawn map suites' seed")
    ap.add_argument("--cases", type=cli.positive_int, default=None,
                    help="cases of each suite to fit on (default: 6; with --robot spatial, 10)")
    ap.add_argument("--held-out", type=cli.positive_int, default=None,
                    help="further cases of each suite to test on (default: 3; with --robot spatial, 5)")
    ap.add_argument("--every", type=cli.positive_int, default=None,
                    help="take every K-th case of a suite (default: 23; with --robot spatial, 10)")
    ap.add_argument("--out", type=cli.output_file(".json"), default=None,
                    help="the file to write (default: drakeslip/multibody/template.json, a hopper file; with --robot "
                         "spatial, drakeslip/spatial/multibody/template.json, the fitted factors)")
    cli.add_parallel(ap, jobs=1)
    return ap


@cli_physics.reports_crashes
def main(argv=None) -> int:
    ap = parser()
    args = ap.parse_args(argv)
    for name, planar, spatial in (("cases", 6, 10), ("held_out", 3, 5), ("every", 23, 10)):
        if getattr(args, name) is None:
            setattr(args, name, spatial if args.robot == "spatial" else planar)
    if args.robot == "spatial":
        return fit_spatial(ap, args, argv)
    if args.jobs != 1 or args.executor != "local" or args.seed != ap.get_default("seed"):
        ap.error("--jobs, --executor and --seed are for --robot spatial: the planar robot's cases run here in turn")
    return fit_planar(ap, args)


def fit_planar(ap, args) -> int:
    """The planar robot's fit (module doc)."""
    args.suites = args.suites or "suites/ditch.json,suites/step.json"
    args.out = args.out or "drakeslip/multibody/template.json"

    from dataclasses import replace

    from drakeslip.hopper_file import NamedHopper, save_hopper
    from drakeslip.multibody.fit import FIT_NAME, by_speed_change, errors, fit, fitted_template, summary
    from drakeslip.params import SlipParams
    from planners.formats.suite import load_suite

    try:
        suites = [load_suite(path) for path in args.suites.split(",")]
    except (OSError, ValueError) as error:
        ap.error(str(error))
    train, test = [], []
    for suite in suites:
        cases = suite.cases[::args.every]
        params = SlipParams(friction=suite.friction)
        train += collect_hops(cases[:args.cases], suite.goal_x, params)
        test += collect_hops(cases[args.cases:args.cases + args.held_out], suite.goal_x, params)
        print(f"{suite.name}: {len(train)} hops to fit, {len(test)} held out so far", flush=True)
    if not train:
        print("no hops recorded")
        return FAILED
    paper = SlipParams()
    fitted = fit(train, paper)
    templates = {"paper": paper, "fitted": fitted}
    current = fitted_template()
    if current is not None:   # the template the multibody backend's planners plan for now
        templates["current"] = current
    report = {}
    for name, t in templates.items():
        err = errors(train + test, t)   # the fitted hops' rows, then the held-out ones'
        report[name] = {"fit": summary(err[:len(train)]), "held_out": summary(err[len(train):]),
                        "by_speed_change": by_speed_change(train + test, err),
                        "leg_length": t.leg_length, "stiffness": t.stiffness}
    print(json.dumps(report, indent=1))
    save_hopper(NamedHopper(replace(fitted, friction=paper.friction), FIT_NAME), args.out)
    print(f"wrote {args.out}")
    return OK


def map_suites(ap, args) -> tuple:
    """(the --suites map suites, or the map families drawn from --seed; the hopper they were drawn for); one line and
    exit status 2 for a file that is not a map suite or suites of different hoppers."""
    from drakeslip.spatial.families import HEIGHT_MAP_FAMILIES
    from planners.formats.map_suite import load_map_suite, make_map_suite
    from planners.formats.suite_draw import suite_hopper

    try:
        if args.suites is None:
            suites = [make_map_suite(family, args.seed + 100 * k) for k, family in enumerate(HEIGHT_MAP_FAMILIES)]
        else:
            suites = [load_map_suite(path) for path in args.suites.split(",")]
    except (OSError, ValueError) as error:
        ap.error(str(error))
    hoppers = {suite.name: suite_hopper(suite) for suite in suites}
    first = next(iter(hoppers.values()))
    other = next((name for name, h in hoppers.items() if h.params.with_friction(first.params.friction)
                  != first.params), None)
    if other is not None:
        ap.error(f"--suites: {other} was drawn for another hopper than {suites[0].name}; fit one hopper at a time")
    return suites, first.params


def fit_spatial(ap, args, argv) -> int:
    """The spatial robot's fit (module doc)."""
    from drakeslip.spatial.multibody.fit import FIT_FILE, SpatialHop, errors, fit_factors, fitted, save_fit, summary
    from verification.robot_hops import map_robot_hops

    suites, hopper = map_suites(ap, args)
    cli.announce(argv)
    tasks, held_out = [], set()
    for suite in suites:
        cases = suite.cases[::args.every]
        for i, case in enumerate(cases[:args.cases + args.held_out]):
            tasks.append((case.id, ("step", case, hopper.with_friction(suite.friction))))
            if i >= args.cases:
                held_out.add(case.id)
    train, test = [], []
    for n, (tag, hops) in enumerate(cli.executor(args).results(map_robot_hops, tasks), 1):
        (test if tag in held_out else train).extend(SpatialHop(**h) for h in hops)
        if n % 10 == 0 or n == len(tasks):
            print(f"{n}/{len(tasks)} cases run: {len(train)} hops to fit, {len(test)} held out", flush=True)
    if not train or not test:
        print(f"{len(train)} hops to fit and {len(test)} held out: too few")
        return FAILED
    factors = fit_factors(train, hopper)
    report = {"hops": {"fit": len(train), "held_out": len(test)}}
    for name, t in (("own", hopper), ("fitted", fitted(hopper, factors))):
        report[name] = {"fit": summary(errors(train, t)), "held_out": summary(errors(test, t))}
    print(json.dumps({"factors": factors, **report}, indent=1))
    out = args.out or FIT_FILE
    save_fit(out, factors, report)
    print(f"wrote {out}")
    return OK


if __name__ == "__main__":
    sys.exit(main())
