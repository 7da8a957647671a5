r"""Plan one suite case with any planner and save the plan as a self-contained JSON file.

The planner sees the perception window around the start apex, as in the receding-horizon evaluation's first
planning call; the file holds the whole terrain, so examples/verify_plan.py checks the plan on the real ground.

    python3 examples/make_plan.py --suite suites/step.json --case 7 --planner step --out out/plan.json
    python3 examples/make_plan.py --suite suites/step.json --case 7 --planner trajopt \
        --options '{"seed": "lstm-guided"}' --out out/trajopt-plan.json
    python3 examples/make_plan.py --hopper my_hopper.json --terrain my_ground.csv --planner step --out out/plan.json
    python3 examples/make_plan.py --suite out/maps/stones-0.json --case 3 --planner step@robust --out out/map-plan.json

The plan is made for the suite's hopper (--hopper, a hopper file or folder, must be that one: its folder's weights
are then read) and recorded in the file. --terrain plans on a terrain file instead of a suite's case, for --hopper
(default: the paper's), from the start plan_and_hop.py takes (--start-x, --speed, --height, --goal as there).

A height-map suite (examples/make_suites.py --families gaps,...) gives a map plan (drakeslip-map-plan/1,
planners/formats/map_plan.py): the planner sees the window the map loop's first planning call sees, and the file
holds the map as the suite records it (a drawn map's family, seed and digest, or a map file's path and digest); its
--plot draws the plan over the map, top view and profile.

--plot PATH.png draws the search tree the planner expanded over the terrain, the plan in bold (the search
planners, angle and step, run their search once more to keep the tree: the same search, the same plan; other
planners' plans are drawn alone).

Exit status: 0 a plan was written, 1 the planner found no plan, 2 a usage or input error, 3 a simulation crashed (one
line naming what failed: drakeslip/jobs/cli.py).
"""
from __future__ import annotations

import math
import sys

from drakeslip.jobs import cli
from drakeslip import cli_physics
from drakeslip.bounds import POSITION, SPEED
from drakeslip.jobs.files import parse_json
from planners.registry import check_label, labels


def arguments() -> cli.ArgumentParser:
    ap = cli.ArgumentParser(__doc__)
    ground = ap.add_mutually_exclusive_group(required=True)
    ground.add_argument("--suite", type=cli.input_file,
                        help="suite file (drakeslip-suite/1, or drakeslip-map-suite/1 for a map plan)")
    ground.add_argument("--terrain", type=cli_physics.terrain_or_family(), help="terrain file (a height profile)")
    ap.add_argument("--case", default=None, help="with --suite: case index (0-based) or case id")
    cli_physics.add_hopper_argument(ap, default="the suite's, else the paper's")
    ap.add_argument("--start-x", type=cli_physics.physical(POSITION), default=None,
                    help="with --terrain: start apex x [m] (default: plan_and_hop.py's)")
    ap.add_argument("--speed", type=cli_physics.physical(SPEED, positive=True), default=None,
                    help="with --terrain: start apex speed [m/s] (default: plan_and_hop.py's, made the hopper's)")
    ap.add_argument("--height", type=cli_physics.physical(POSITION, positive=True), default=None,
                    help="with --terrain: start apex height above the ground [m] (default: plan_and_hop.py's)")
    ap.add_argument("--goal", type=cli_physics.physical(POSITION), default=None,
                    help="with --terrain: goal x [m] (default: plan_and_hop.py's, made the hopper's)")
    ap.add_argument("--planner", required=True, help=f"planner label: one of {', '.join(labels())}, or NAME@VARIANT")
    ap.add_argument("--options", default="{}",
                    help='the planner\'s options as a JSON object, e.g. \'{"seed": "lstm-guided"}\' for trajopt')
    ap.add_argument("--out", type=cli.output_file(".json"), required=True, help="plan file to write (JSON)")
    ap.add_argument("--plot", type=cli.output_file(".png"), default=None,
                    help="also draw the search tree over the terrain (PNG)")
    return ap


def checked_options(ap: cli.ArgumentParser, args) -> dict:
    """--options as a dict, or one line and exit status 2."""
    try:
        options = parse_json(args.options, "--options")
    except ValueError as error:
        ap.error(str(error))
    if not isinstance(options, dict):
        ap.error(f"--options must be a JSON object of planner options, got {args.options!r}")
    return options


def checked_case(ap: cli.ArgumentParser, args, options: dict):
    """(the suite, its hopper, the planner, the case to plan): a suite's case, or the one case of --terrain; or one
    line and exit status 2 for a bad suite, terrain, hopper, planner label or case."""
    from drakeslip.jobs.files import read_json
    from planners.base import Planner
    from planners.formats.map_suite import MapSuite, is_map_suite, load_map_suite
    from planners.formats.suite import load_suite
    from planners.formats.suite_draw import hopper_for_suite, one_case
    from planners.registry import hopper_specs, make_planners

    if (args.suite is None) != (args.case is None):
        ap.error("--case goes with --suite (and --suite needs it)")
    check_start_options(ap, args)
    try:
        if args.suite is not None:
            suite = load_map_suite(args.suite) if is_map_suite(read_json(args.suite, "suite file")) else \
                load_suite(args.suite)
            hopper = hopper_for_suite(suite, args.hopper)
        else:
            suite = one_case(args.terrain.terrain, hopper=args.hopper, speed=args.speed, height=args.height,
                             goal_x=args.goal, start_x=args.start_x)
            hopper, args.case = hopper_for_suite(suite, args.hopper), "0"
        planner = make_planners(hopper_specs({check_label(args.planner): options}, hopper))[args.planner]
        if isinstance(suite, MapSuite) and type(planner).plan_on_map is Planner.plan_on_map:
            raise ValueError(f"--planner {args.planner} plans on profiles only, not on the height maps of {args.suite}")
    except (OSError, ValueError) as error:
        ap.error(str(error))
    ids = [c.id for c in suite.cases]
    if args.case in ids:
        index = ids.index(args.case)
    elif args.case.isdigit() and int(args.case) < len(ids):
        index = int(args.case)
    else:
        ap.error(f"--case {args.case!r} is neither a case id nor an index below {len(ids)} in {args.suite}")
    return suite, hopper, planner, index


def check_start_options(ap: cli.ArgumentParser, args) -> None:
    """One line and exit status 2 for a start or goal option given with --suite: the suite's case has its own."""
    given = [flag for flag, value in (("--start-x", args.start_x), ("--speed", args.speed), ("--height", args.height),
                                      ("--goal", args.goal)) if value is not None]
    if args.suite is not None and given:
        ap.error(f"{', '.join(given)} go{'es' if len(given) == 1 else ''} with --terrain: a --suite case has its "
                 "own start and goal")


@cli_physics.reports_crashes
def main(argv=None) -> int:
    ap = arguments()
    args = ap.parse_args(argv)
    options = checked_options(ap, args)
    suite, hopper, planner, index = checked_case(ap, args, options)

    from planners.formats.map_suite import MapSuite

    if isinstance(suite, MapSuite):
        return map_plan(planner, suite, index, hopper, args)

    from drakeslip.units import units_of
    from planners.formats.plan import save_plan

    case, params = suite.cases[index], hopper.params.with_friction(suite.friction)
    window = case.terrain.perceived(case.apex.x, *units_of(params).window)
    plan = planner.plan(case.apex, window, suite.goal_x, params)
    if args.plot:
        plot_tree(planner, plan, case, window, suite.goal_x, params, args)
    if not plan.success:
        print(f"{args.planner} on {case.id}: {plan.message}")
        return cli.FAILED
    save_plan(args.out, plan, case.apex, case.terrain, suite.goal_x, params, hopper)
    print(f"{args.planner} on {case.id}: {len(plan.footholds)} footholds to x={plan.footholds[-1]:.3f} "
          f"(target {plan.target_x:g}) in {plan.time_s:.3f} s; wrote {args.out}")
    return cli.OK


def map_plan(planner, suite, index: int, hopper, args) -> int:
    """The plan of a map suite's case from the window its first planning call sees, saved as a map plan."""
    from planners.formats.map_plan import save_map_plan
    from planners.spatial_loop import perception_window

    case, params = suite.cases[index], hopper.params.with_friction(suite.friction)
    plan = planner.plan(case.apex, perception_window(case.terrain, case.apex, case.goal, params), case.goal, params)
    if not plan.success:
        print(f"{args.planner} on {case.id}: {plan.message}")
        return cli.FAILED
    record = save_map_plan(args.out, plan, case, suite.sources[index], params, hopper)
    last = record.footholds[-1]
    print(f"{args.planner} on {case.id}: {len(record.footholds)} footholds to ({last[0]:.3f}, {last[1]:.3f}) (target "
          f"({record.target[0]:g}, {record.target[1]:g})) in {plan.time_s:.3f} s; wrote {args.out}")
    if args.plot:
        from drakeslip.spatial.viz import plot_run3d

        path = [case.apex[:3]] + [a[:3] for a in record.apexes if all(map(math.isfinite, a))]
        args.plot.parent.mkdir(parents=True, exist_ok=True)
        plot_run3d(case.terrain, path, [], record.footholds, None, f"{args.planner} on {case.id}: the plan, "
                   f"{len(record.footholds)} footholds; {plan.ode_calls} step-map calls", args.plot, goal=case.goal)
        print(f"figure: {args.plot}")
    return cli.OK


def plot_tree(planner, plan, case, window, goal_x, params, args):
    """The search tree over the case's terrain: a search planner's whole tree (its search run again, kept), or
    for the others the plan's own branch."""
    import numpy as np

    from drakeslip.viz import new_axes, plot_search_tree

    if hasattr(planner, "search"):  # the angle- and step-space planners: the search behind the plan
        tree = planner.search(case.apex, window, goal_x, params).tree
        parent, foothold, apex = tree.parent, tree.foothold, tree.apex
        best = tree.branch(tree.goals[0]) if tree.goals else []
        what = f"search tree: {len(tree)} nodes, {len(tree.expanded)} expanded"
    else:
        n = len(plan.footholds)
        parent, foothold = list(range(-1, n)), [np.nan, *plan.footholds]
        apex, best = [tuple(case.apex), *map(tuple, plan.apexes)], list(range(1, n + 1))
        what = f"no search tree (the {plan.planner} planner does not search): its plan"
    ax = new_axes((12, 4.2))
    lines = plot_search_tree(ax, case.terrain, parent, foothold, apex, best)
    ax.figure.colorbar(lines, ax=ax, label="depth [hops from the start]", pad=0.01)
    ax.axvline(plan.target_x, color="green", ls=":", lw=1.5, label=f"target x = {plan.target_x:g} m")
    ax.set_title(f"{args.planner} on {case.id}: {what}; {plan.ode_calls} ODE calls, "
                 f"{'plan found' if plan.success else 'no plan'}", fontsize=10)
    ax.figure.legend(loc="outside lower center", fontsize=8, ncols=5, frameon=False)
    args.plot.parent.mkdir(parents=True, exist_ok=True)
    ax.figure.savefig(args.plot, dpi=120)
    print(f"figure: {args.plot}")


if __name__ == "__main__":
    sys.exit(main())
