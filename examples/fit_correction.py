"""Train the learned correction of the fitted template's apex-to-apex map toward the multibody robot's, measure it on
held-out hops, and name it in the template the robot's planners plan for.

    python3 examples/fit_correction.py --jobs 2     # 7 min on 2 cores: drakeslip/multibody/template_correction.npz
                                                    # and template_corrected.json naming it, as committed

Draws --cases cases of each --families suite (seed --seed, the paper's suites' kinds) for --hopper (default: the
paper's), runs each on that hopper's robot's closed loop without noise with step@robust planning for the fitted
template's SLIP (--template, fitted to the paper's hopper's robot and made the hopper's robot's,
drakeslip.multibody.fit.template_for; its correction left out), and records every hop the robot flew aiming at a
plan's foothold with the plan's energy, with the hop before it (verification/robot_hops.py); the hops are kept in
--hops as the cases run, and a rerun of the same code and setup takes them from there. Every --held-out-th case of
each suite is held out. Trains the correction
(drakeslip/apex_correction.py, drakeslip/multibody/correction_training.py) on the other cases' hops and prints the
held-out hops' errors (median and 90th percentile of |error| in x, z [m] and xdot [m/s]) of the template, of the
template with the correction, and of that with the hop before unknown (as a plan's first hop is predicted), also by
the hop's speed change (m/s bands). Writes the weights beside --out (STEM_correction.npz, STEM the --template file's)
and, to --out, the template with the correction named by the weights file's name and SHA-256, which loading checks
(``evaluate.py --backend multibody --template`` plans for it on the hopper's suites).
Exit status: 0 written, 1 too few hops recorded, 2 bad input, 3 a simulation crashed (one line naming what failed:
drakeslip/jobs/cli.py).
"""
from __future__ import annotations

import json
import sys

from drakeslip.jobs import cli
from drakeslip import cli_physics
from drakeslip.devices import DEVICE_HELP

OK, FAILED = 0, 1


def parser() -> cli.ArgumentParser:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--families", type=cli.names, default="ditch,step,mixed", help="the suites' terrain families")
    ap.add_argument("--seed", type=cli.integer(0), default=41000, help="the drawn suites' seed")
    ap.add_argument("--cases", type=cli.positive_int, default=150, help="cases of each family's suite to run")
    ap.add_argument("--held-out", type=cli.integer(2), default=5, help="hold out every K-th case")
    ap.add_argument("--epochs", type=cli.positive_int, default=3000, help="full-batch training epochs")
    ap.add_argument("--device", default="auto", help=DEVICE_HELP)
    cli_physics.add_hopper_argument(ap)
    ap.add_argument("--template", type=cli.input_file, default="drakeslip/multibody/template.json",
                    help="the template hopper file fitted to the paper's hopper's robot, made the --hopper's robot's: "
                         "the SLIP its planners plan for, which the correction corrects")
    ap.add_argument("--out", type=cli.output_file(".json"), default="drakeslip/multibody/template_corrected.json",
                    help="the corrected template's hopper file to write (the weights go beside it)")
    ap.add_argument("--hops", type=cli.output_file(".json"), default="out/robot_hops.json",
                    help="the recorded hops, kept as the cases run: a rerun of the same code and setup takes the "
                         "cases it holds from it")
    cli.add_parallel(ap, jobs=1)
    return ap


def recorded_hops(args, suites, template, kept: dict) -> dict:
    """{case id: its hops' records} for the first --cases cases of each suite run on the robot planning for the
    SLIP ``template``: those of ``kept`` (the --hops file's contents) where it was written by this code for this
    template, the others run, --hops rewritten as they finish."""
    from dataclasses import asdict

    from drakeslip.jobs.files import atomic_write
    from verification.provenance import code_version
    from verification.robot_hops import hop_record, robot_hops

    from drakeslip.multibody.robot import RobotParams

    robot = RobotParams.for_hopper(template_hopper(args).params)
    setup = {"code": code_version(), "template": asdict(template), "robot": robot.to_dict()}
    records = dict(kept.get("cases", {})) if kept.get("setup") == json.loads(json.dumps(setup)) else {}
    tasks = [(case.id, ("step@robust", case, suite.goal_x, template.with_friction(suite.friction), robot))
             for suite in suites for case in suite.cases[:args.cases] if case.id not in records]
    print(f"{len(records)} cases from {args.hops}, {len(tasks)} to run", flush=True)
    for n, (tag, hops) in enumerate(cli.executor(args).results(robot_hops, tasks), 1):
        records[tag] = [hop_record(h) for h in hops]
        if n % 25 == 0 or n == len(tasks):
            with atomic_write(args.hops, "w") as f:
                json.dump({"setup": setup, "cases": records}, f)
            print(f"{n}/{len(tasks)} cases run", flush=True)
    return records


def template_hopper(args):
    """The hopper whose robot runs: --hopper, the paper's by default."""
    from drakeslip.hopper_file import paper_hopper

    return args.hopper or paper_hopper()


def print_errors(train, test, template, arrays) -> None:
    """The held-out hops' errors of the template, the template with the correction, and that with the hop before
    each unknown, overall and by speed change."""
    from dataclasses import replace

    from drakeslip.multibody.correction_training import corrected_errors
    from drakeslip.multibody.fit import by_speed_change, errors, summary

    first_hops = [replace(h, previous=None) for h in test]   # as a plan's first hop is predicted
    report = {"hops": {"train": len(train), "held_out": len(test)}}
    for name, err in (("template", errors(test, template)),
                      ("template+correction", corrected_errors(test, template, arrays)),
                      ("template+correction, hop before unknown", corrected_errors(first_hops, template, arrays))):
        report[name] = {"held_out": summary(err), "by_speed_change": by_speed_change(test, err)}
    print(json.dumps(report, indent=1))


@cli_physics.reports_crashes
def main(argv=None) -> int:
    ap = parser()
    args = ap.parse_args(argv)

    from dataclasses import asdict
    from pathlib import Path

    from drakeslip.apex_correction import load_correction, save_correction
    from drakeslip.devices import torch_device
    from drakeslip.hopper_file import NamedHopper, load_hopper, save_hopper
    from drakeslip.jobs.files import read_json
    from drakeslip.multibody.correction_training import CorrectionConfig, train_correction
    from drakeslip.multibody.fit import template_for
    from drakeslip.params import RobotTemplate
    from planners.formats.suite_draw import draw_suite
    from verification.robot_hops import hop_from_record

    try:
        hopper = template_hopper(args)
        suites = [draw_suite(family, args.seed + 1000 * k, hopper) for k, family in enumerate(args.families)]
        torch_device(args.device)
        named = load_hopper(args.template)
        fitted = named.params.slip if isinstance(named.params, RobotTemplate) else named.params
        template = template_for(hopper.params, fitted)
        kept = read_json(args.hops, "hop file") if Path(args.hops).is_file() else {}
    except (OSError, ValueError) as error:
        ap.error(str(error))
    cli.announce(argv)
    records = recorded_hops(args, suites, template, kept if isinstance(kept, dict) else {})
    train, test = [], []
    for suite in suites:
        for i, case in enumerate(suite.cases[:args.cases]):
            (test if i % args.held_out == 0 else train).extend(hop_from_record(r) for r in records[case.id])
    if len(train) < 10 or not test:
        print(f"{len(train)} hops to train on and {len(test)} held out: too few")
        return FAILED
    try:
        arrays = train_correction(train, test, template, CorrectionConfig(epochs=args.epochs, device=args.device))
    except ValueError as error:
        print(error)
        return FAILED
    print_errors(train, test, template, arrays)
    weights = Path(args.out).with_name(Path(args.template).stem + "_correction.npz")
    save_correction(weights, arrays)
    robot = RobotTemplate(**asdict(template), correction=load_correction(weights))
    save_hopper(NamedHopper(robot, f"{named.name}-corrected"), args.out)
    print(f"wrote {weights} (sha256 {robot.correction.sha256}) and {args.out}")
    return OK


if __name__ == "__main__":
    sys.exit(main())
