"""Fit the SLIP template to the multibody robot and write it as a hopper file the planners plan for.

    python3 examples/fit_template.py --cases 6 --out drakeslip/multibody/template.json

Runs --cases cases of each suite (every --every-th) in the robot's closed loop with step@robust, records every
hop (apex, foothold -> next apex), fits the template's leg length and stiffness to the robot's apex-to-apex map
(drakeslip/multibody/fit.py), prints the per-hop prediction errors (median and 90th percentile in x, z, xdot) of
the paper's template, of the fitted one and of the one the planners use now ("current", when there is one), on
the hops fitted and on held-out hops (the next cases), and over all of them by the hop's speed change
("by_speed_change", m/s bands), and writes the fitted template (drakeslip-hopper/1; the
multibody backend's planners plan for the one at the default --out). Exit status: 0 written, 1 no hops
recorded, 2 bad input, 3 a simulation crashed (one line naming what failed: drakeslip/jobs/cli.py).
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


@cli_physics.reports_crashes
def main(argv=None) -> int:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--suites", default="suites/ditch.json,suites/step.json", help="suites whose cases to run")
    ap.add_argument("--cases", type=cli.positive_int, default=6, help="cases of each suite to fit on")
    ap.add_argument("--held-out", type=cli.positive_int, default=3, help="further cases of each suite to test on")
    ap.add_argument("--every", type=cli.positive_int, default=23, help="take every K-th case of a suite")
    ap.add_argument("--out", type=cli.output_file(".json"), default="drakeslip/multibody/template.json",
                    help="the hopper file to write")
    args = ap.parse_args(argv)

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


if __name__ == "__main__":
    sys.exit(main())
