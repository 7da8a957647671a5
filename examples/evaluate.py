r"""Receding-horizon evaluation of planners on a suite (the paper's Tables II/III).

    python3 examples/evaluate.py --suite suites/ditch.json --planners heuristic,angle,step --jobs 2 --out out/ditch.json

Each planning call sees the 8 m / 3 m perception window; the first 3 footholds of each plan are executed by the
controller on the Drake simulator (--backend fast: on the fast step map), then it replans. Finished cases are
kept in OUT.cases.jsonl, keyed by the code version (git commit and a digest of uncommitted changes), the options
and the weights' digests, so the same command continues a killed or interrupted run where it stopped, and after
a code change runs the cases again (it says how many cached results it reused and ignored; --no-resume starts
over). Two settings of one planner run side by side as NAME@VARIANT, with their options keyed by that label:

    python3 examples/evaluate.py --suite suites/ditch.json --planners lstm-guided,lstm-guided@paper \
        --backend fast --jobs 2 --out out/guided.json

Planning on the Drake model itself (each candidate hop simulated on Drake, about 0.1 s a hop) is slow, so take
a spread-out sample of the cases:

    python3 examples/evaluate.py --suite suites/ditch.json --every 13 --cases 10 --planners step,lstm-guided \
        --options '{"step": {"step_map": "drake"}, "lstm-guided": {"step_map": "drake"}}' --baseline step \
        --out out/drake.json

A height-map suite (examples/make_suites.py --families gaps,stones,stairs,blocks,course; format
drakeslip-map-suite/1, planners/formats/map_suite.py) is taken the same way: each case runs in the receding-horizon
loop on its map (planners/spatial_loop.py: the window ahead and aside, the plan's first footholds flown on Drake's
spatial SLIP, or with --backend fast on the compiled spatial step map), through the same cache, and the same table
is printed, with or without a noise profile (its 3D form, drakeslip/spatial/noise.py) and the robot's map filter.
--backend multibody runs each map case on the spatial robot (drakeslip/spatial/multibody, any hopper's: one Diagram
per case with the map loop as a planner system, planners/spatial_robot_loop.py), the planners planning for the
hopper's own SLIP, or with --template for a SLIP fitted to the spatial robot (examples/fit_template.py --robot
spatial); --no-pump and --mlp-only are refused on maps, as are planners that plan on profiles only:

    python3 examples/evaluate.py --suite out/maps/gaps-7000.json --planners step --backend fast --jobs 2 \
        --out out/gaps.json

The planners plan for the suite's hopper (the paper's when it records none), and the results record it. --hopper (a
hopper file or folder, examples/train_hopper.py) must be that hopper, whose folder's weights the planners then
read; a suite drawn for another hopper is refused in one line (examples/make_suites.py --hopper draws one for it).
--backend multibody on a planar suite runs the paper's hopper only (the planar robot and its fitted template are built
for it); a planar suite of another hopper is refused in one line.

Exit status: 0 when the evaluation ran (whatever the planners' success), 2 for a usage or input error (a suite value
outside the bounds of drakeslip/bounds.py included), refused in one line before any case runs, 3 a simulation crashed
(one line naming what failed: drakeslip/jobs/cli.py). Ctrl-C ends it with one line saying how many results were saved,
and by SIGINT (a shell shows status 130).
"""
from __future__ import annotations

import sys

from drakeslip.jobs import cli
from drakeslip import cli_physics
from drakeslip.noise import PROFILES
from drakeslip.terrain import check_window
from planners.closed_loop import ClosedLoopConfig
from planners.registry import check_label, label_options, loop_settings


def arguments() -> cli.ArgumentParser:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--suite", type=cli.input_file, required=True,
                    help="suite file (format drakeslip-suite/1, or drakeslip-map-suite/1: height maps)")
    ap.add_argument("--planners", type=cli.names, default="heuristic,angle,step",
                    help="planner labels, comma-separated: a name or NAME@VARIANT (a preset such as lstm@paper, or "
                         "any variant with options from --options)")
    ap.add_argument("--cases", type=cli.positive_int, default=None, help="only the first N cases (after --every)")
    ap.add_argument("--every", type=cli.positive_int, default=1,
                    help="every K-th case (suites list 10 starts per terrain: K = 7 or 13 spreads a few cases over "
                         "the terrains and starts)")
    ap.add_argument("--out", type=cli.output_file(".json", beside=(".cases.jsonl",)), required=True,
                    help="results JSON (written atomically)")
    ap.add_argument("--options", default="{}",
                    help='planner options as JSON keyed by label, e.g. \'{"angle": {"branching": 15, "seed": 1}}\'')
    cli_physics.add_hopper_argument(ap, default="the suite's")
    ap.add_argument("--controller", type=cli.input_file, default=None,
                    help="controller weights (default: the committed drakeslip/weights/controller.pt)")
    ap.add_argument("--executed", type=cli.positive_int, default=None,
                    help="footholds of each plan executed before replanning (default: the label's preset's "
                         f"period, else {ClosedLoopConfig.executed_per_plan}, the paper's)")
    ap.add_argument("--map-filter", type=cli.positive_int, default=None,
                    help="cells of the median filter the robot runs on its sensed height map, odd (default: the "
                         f"label's preset's, else {ClosedLoopConfig.map_filter}: the map as sensed)")
    ap.add_argument("--noise", type=cli_physics.noise_profile, default="none",
                    help=f"noise profile: {', '.join(PROFILES)}, or NAME*K scaled by K (drakeslip/noise.py)")
    ap.add_argument("--seed", type=cli.non_negative_int, default=0, help="seed of the noise draws")
    ap.add_argument("--backend", choices=("drake", "fast", "multibody"), default="drake",
                    help="what executes the plans: the Drake simulator of the SLIP (the protocol), the fast step "
                         "map, or the multibody robot (drakeslip/multibody: one closed-loop Diagram per case)")
    ap.add_argument("--template", type=cli.input_file, default=None,
                    help="multibody backend: the template hopper file the planners plan for (default: the one fitted "
                         "to the paper's hopper's robot, drakeslip/multibody/template.json, whose fit another hopper's "
                         "robot takes as factors; drakeslip/multibody/template_corrected.json, the paper's robot's, "
                         "adds the learned correction of its apex-to-apex map, examples/fit_correction.py); on a map "
                         "suite, a spatial template fit (examples/fit_template.py --robot spatial; default: the "
                         "hopper's own SLIP)")
    ap.add_argument("--no-pump", action="store_true",
                    help="ablation, multibody backend: the robot does not raise its apex with its leg actuator "
                         "where a plan skims the ground (drakeslip.multibody.pump.EnergyPump)")
    ap.add_argument("--mlp-only", action="store_true",
                    help="ablation: the controller without its Newton polish (the paper's MLP controller)")
    ap.add_argument("--baseline", default=None,
                    help="also print this planner's ODE calls and planning time over each other planner's")
    ap.add_argument("--no-resume", action="store_true", help="ignore and replace the case cache")
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    cli.add_parallel(ap)
    return ap


def checked_labels(ap: cli.ArgumentParser, args) -> tuple[list[str], dict]:
    """(the planner labels, their options from --options), or one line and exit status 2."""
    try:
        labels = [check_label(label) for label in args.planners]
        options = label_options(args.options, labels)
    except ValueError as error:
        ap.error(str(error))
    if args.no_pump and args.backend != "multibody":
        ap.error(f"--no-pump needs --backend multibody, got --backend {args.backend}")
    if args.baseline is not None and args.baseline not in labels:
        ap.error(f"--baseline {args.baseline!r} is not among --planners {labels}")
    return labels, options


def loop_configs(ap: cli.ArgumentParser, args, labels: list[str], maps: bool) -> dict:
    """{label: the ClosedLoopConfig its cases run with}, or one line and exit status 2 for a bad --map-filter. On a map
    suite the robot's parameters come with the suite's hopper (``checked_suite``)."""
    loop_options = {name: value for name, value in (("executed_per_plan", args.executed),
                                                     ("map_filter", args.map_filter)) if value is not None}
    if args.map_filter is not None:
        try:
            check_window(args.map_filter, "map_filter")
        except ValueError as error:
            ap.error(f"--map-filter: {error}")
        if args.noise.silent:   # the robot filters the map it senses; without noise it sees the map itself
            ap.error(f"--map-filter {args.map_filter} filters the map a noisy robot senses: give --noise")
    if args.backend == "multibody" and not maps:   # the planners plan for the template fitted to the robot
        from drakeslip.hopper_file import load_hopper
        from drakeslip.multibody.fit import fitted_template

        try:
            loop_options["template"] = fitted_template() if args.template is None else load_hopper(args.template).params
        except (OSError, ValueError) as error:
            ap.error(f"--template: {error}")
        loop_options["pump_energy"] = not args.no_pump
    elif args.template is not None and args.backend != "multibody":
        ap.error(f"--template needs --backend multibody, got --backend {args.backend}")
    return {label: ClosedLoopConfig(**{**loop_settings(label), **loop_options}, backend=args.backend,
                                    refine=not args.mlp_only, noise=args.noise, seed=args.seed)
            for label in labels}


def on_maps(ap: cli.ArgumentParser, args) -> bool:
    """Whether --suite is a height-map suite (by its format); one line and exit status 2 for a file that is not
    JSON. On one, an option the map loop does not apply is refused in one line, exit status 2."""
    from drakeslip.jobs.files import read_json
    from planners.formats.map_suite import is_map_suite

    try:
        maps = is_map_suite(read_json(args.suite, "suite file"))
    except (OSError, ValueError) as error:
        ap.error(str(error))
    if maps and args.no_pump:
        ap.error(f"--no-pump: not applied on height maps ({args.suite} is a map suite: the spatial robot has no "
                 "energy pump)")
    if maps and args.mlp_only:
        ap.error(f"--mlp-only: not applied on height maps ({args.suite} is a map suite: the spatial controller aims "
                 "by Newton's method and has no MLP)")
    return maps


def checked_suite(ap: cli.ArgumentParser, args, labels: list[str], options: dict, configs: dict, maps: bool):
    """(the suite, {label: its planner spec for the suite's hopper}, {label: its ClosedLoopConfig}, on a map suite on
    the robot with the spatial robot of the suite's hopper), the workers' weights read; or one line and exit
    status 2 for a malformed suite, another hopper's suite, a bad option, a missing or damaged weights file, and on
    a map suite a planner that plans on profiles only or a loop the map loop does not run (a preset's map filter)."""
    from drakeslip.jobs.executors import prepare
    from planners.formats.map_suite import load_map_suite
    from planners.formats.suite import load_suite
    from planners.formats.suite_draw import hopper_for_suite
    from planners.registry import hopper_specs
    from verification.evaluation import check_map_planners, check_map_run, worker_setup

    specs = {label: options.get(label) for label in labels}
    try:
        suite = load_map_suite(args.suite) if maps else load_suite(args.suite)
        hopper = hopper_for_suite(suite, args.hopper)
        if maps:
            check_map_run(configs)
            template = map_template(ap, args, hopper)
        planar_template = next(iter(configs.values())).template
        if args.backend == "multibody" and not maps and planar_template is not None:
            from drakeslip.multibody.fit import template_for

            template_for(hopper.params, planar_template)   # refused where it cannot be the robot's
        specs = hopper_specs(specs, hopper)
        prepare(worker_setup(specs, args.controller, not args.mlp_only))
        if maps:
            check_map_planners()
    except (OSError, ValueError) as error:  # a malformed suite, a bad option, a missing or damaged weights file
        ap.error(f"--{error}" if str(error).startswith("options for") else str(error))
    if maps and args.backend == "multibody":
        from dataclasses import replace

        from drakeslip.spatial.multibody.robot import SpatialRobotParams

        robot = SpatialRobotParams.for_hopper(hopper.params.with_friction(suite.friction))
        configs = {label: replace(config, robot=robot, template=template) for label, config in configs.items()}
    return suite, specs, configs


def map_template(ap: cli.ArgumentParser, args, hopper):
    """The SLIP the planners plan for on the spatial robot: --template's fit applied to ``hopper``'s, None (the
    hopper's own) without one; one line and exit status 2 for a file that is not a fit."""
    if args.template is None:
        return None
    from drakeslip.spatial.multibody.fit import fitted_template

    try:
        return fitted_template(hopper.params, args.template)
    except ValueError as error:
        ap.error(f"--template: {error}")


@cli_physics.reports_crashes
def main(argv=None) -> int:
    ap = arguments()
    args = ap.parse_args(argv)
    labels, options = checked_labels(ap, args)
    executor = cli.executor(args)
    maps = on_maps(ap, args)
    configs = loop_configs(ap, args, labels, maps)
    suite, specs, configs = checked_suite(ap, args, labels, options, configs, maps)
    cli.announce(argv)

    from drakeslip.jobs.runner import remove, write_json
    from verification.evaluation import evaluate
    from verification.report import outcomes, ratios, table

    cache = str(args.out) + ".cases.jsonl"
    if args.no_resume:
        remove(cache)
    results = evaluate(suite, specs, n_cases=args.cases,
                       every=args.every, executor=executor, cache_path=cache, controller_path=args.controller,
                       config=configs, progress=not args.quiet)
    write_json(args.out, results)
    print(table(results))
    print(outcomes(results))
    if args.baseline:
        print(ratios(results, args.baseline))
    print(f"wrote {args.out}")
    return cli.OK


if __name__ == "__main__":
    sys.exit(main())
