"""How likely is a saved plan to work on a noisy robot? Monte Carlo over a noise profile, with the margins that
explain the answer.

    python3 examples/robustness.py --plan out/plan.json --noise realistic --samples 2000 --seed 0 --hops 3 --drake 10

Each draw is a robot from the profile (drakeslip/noise.py): a start off the plan's by the state-estimation error,
an apex told with an error at every hop, a leg reaching its angle with the actuation error, a hopper whose
stiffness, mass and friction differ from the model's, a terrain map with the perception errors. It executes the
plan's footholds through the controller, without replanning, for the plan's first --hops hops. The draws run on
the fast backend; --drake K reruns the first K on Drake. The plan's own margins on Drake (spring travel left,
friction to spare, distance of its footholds from edges) are printed first: they are what noise eats into.

A map plan (drakeslip-map-plan/1, examples/make_plan.py on a height-map suite) draws the profile's 3D form
(drakeslip/spatial/noise.py: apex errors in x, y, z, xdot, ydot, both leg angles, the map's heights and a shift in x
and y) and runs on the spatial SLIP's fast step map (--drake K reruns on its Drake simulator) or, with --backend
multibody, on the spatial robot built for each draw's hopper, whose own estimation and actuation take the apex and
angle errors' place (verification/map_robustness.py); its margins are verify_plan.py's on the map.

--out writes the result as JSON (the rate, the failures, every draw's errors and outcome, where the result came
from, and the plan's hopper); --hopper checks the plan against a hopper file or folder (a plan made for another
hopper is refused in one line); --plot draws the draws in (apex error, leg-angle error) space coloured by outcome
(PNG).

Exit status: 0 when the draws ran, 2 for a usage or input error, 3 a simulation crashed (one line naming what failed:
drakeslip/jobs/cli.py).
"""
from __future__ import annotations

import sys
import time

from drakeslip.jobs import cli
from drakeslip import cli_physics
from drakeslip.noise import PROFILES
from drakeslip.terrain import check_window
from verification.robustness import MAX_SAMPLES


def arguments() -> cli.ArgumentParser:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--plan", type=cli.input_file, required=True,
                    help="plan file (drakeslip-plan/2 JSON, or drakeslip-map-plan/1)")
    cli_physics.add_hopper_argument(ap, default="the plan file's")
    ap.add_argument("--noise", type=cli_physics.noise_profile, default="realistic",
                    help=f"noise profile: {', '.join(PROFILES)}, or NAME*K scaled by K")
    ap.add_argument("--map-filter", type=cli.positive_int, default=1,
                    help="cells of the median filter each robot runs on its sensed height map, odd (1: the map as "
                         "sensed; the robust presets' robots use 5)")
    ap.add_argument("--samples", type=cli.integer(1, MAX_SAMPLES), default=1000, help="Monte Carlo draws")
    ap.add_argument("--seed", type=cli.non_negative_int, default=0, help="seed of the draws")
    ap.add_argument("--hops", type=cli.positive_int, default=None,
                    help="count a draw a success when it completes the plan's first HOPS hops (default: all of them)")
    ap.add_argument("--drake", type=cli.non_negative_int, default=0, metavar="K",
                    help="rerun the first K draws on Drake and report agreement")
    ap.add_argument("--backend", choices=("fast", "multibody"), default="fast",
                    help="what runs the draws: the fast step map, or the multibody robot (drakeslip/multibody, "
                         "drakeslip/spatial/multibody for a map plan: about a second per hop)")
    ap.add_argument("--out", type=cli.output_file(".json"), default=None, help="also write the result (JSON)")
    ap.add_argument("--plot", type=cli.output_file(".png"), default=None,
                    help="also draw the draws by outcome in (apex error, leg-angle error) space (PNG)")
    return ap


def checked_plan(ap: cli.ArgumentParser, args):
    """The plan file's record, or one line and exit status 2 for flags that do not go together, a bad --map-filter
    or one without noise, a malformed plan file, another hopper's plan or more --hops than the plan has."""
    if args.backend == "multibody" and args.drake:
        ap.error("--drake compares fast-backend draws with Drake: use it with --backend fast")
    if args.drake > args.samples:
        ap.error(f"--drake {args.drake} is more than --samples {args.samples}")
    try:
        check_window(args.map_filter, "--map-filter")
    except ValueError as error:
        ap.error(str(error))
    if args.map_filter != 1 and args.noise.silent:   # a silent profile senses the map exactly: nothing to filter
        ap.error(f"--map-filter {args.map_filter} filters the map a noisy robot senses: give --noise")

    from drakeslip.hopper_file import check_same_hopper
    from drakeslip.jobs.files import read_json
    from planners.formats.map_plan import is_map_plan, load_map_plan
    from planners.formats.plan import load_plan

    try:
        on_map = is_map_plan(read_json(args.plan, "plan file"))
        record = load_map_plan(args.plan) if on_map else load_plan(args.plan)
        if args.hopper is not None:
            check_same_hopper(args.hopper, record.params, f"plan file {args.plan}")
        if args.hops is not None and args.hops > len(record.footholds):
            raise ValueError(f"--hops {args.hops} is more than the plan's {len(record.footholds)} hops")
    except (OSError, ValueError) as error:
        ap.error(str(error))
    return record


def print_margins(record) -> None:
    """The plan on Drake without noise: its margins, or where it fails."""
    from planners.formats.map_plan import MapPlanRecord
    from verification.map_plan_check import check_map_plan
    from verification.plan_check import check_plan
    from verification.plan_check_options import TOLERANCE

    if isinstance(record, MapPlanRecord):
        nominal = check_map_plan(record, "footholds", TOLERANCE)
        print(f"{record.planner} plan on a height map, {len(record.footholds)} footholds; on Drake without noise: "
              + ("the plan as written, margins:" if nominal.ok else nominal.reason()))
        for name, (value, hop) in (nominal.margins or {}).items():
            print(f"  {name:<15} {value:9.4f} (hop {hop})")
        return
    nominal = check_plan(record, "footholds")
    print(f"{record.planner} plan, {len(record.footholds)} footholds; on Drake without noise: "
          + ("the plan as written, margins:" if nominal.ok else nominal.reason()))
    if nominal.ok:
        for name, margin in nominal.margins().items():
            print(f"  {name:<15} {margin.value:9.4f} (hop {margin.hop})")


def drawn(args, record) -> dict:
    """The Monte Carlo draws (and their reruns on Drake with --drake), printed, as the result document."""
    from drakeslip.hopper_file import hopper_for
    from planners.formats.map_plan import MapPlanRecord
    from verification.map_robustness import confirm_map_on_drake, map_success_probability
    from verification.provenance import provenance
    from verification.robustness import confirm_on_drake, success_probability

    on_map = isinstance(record, MapPlanRecord)
    t0 = time.perf_counter()
    result = (map_success_probability if on_map else success_probability)(
        record, args.samples, args.noise, args.seed, backend=args.backend, hops=args.hops, map_filter=args.map_filter)
    print(f"{time.perf_counter() - t0:.2f} s")
    print(result.format())
    if args.drake:
        t0 = time.perf_counter()
        confirmation = (confirm_map_on_drake if on_map else confirm_on_drake)(result, args.drake)
        print(confirmation.format() + f" ({time.perf_counter() - t0:.1f} s)")
    document = {**result.to_dict(), "plan": str(args.plan),
                "hopper": (record.hopper or hopper_for(record.params)).to_record(), "provenance": provenance()}
    if args.backend == "multibody":   # the robot each draw ran: built around the draw's hopper
        from drakeslip.multibody.robot import RobotParams
        from drakeslip.spatial.multibody.robot import SpatialRobotParams
        from planners.replanning import robot_record

        document["robot"] = robot_record(SpatialRobotParams.for_hopper(record.params) if on_map else
                                         RobotParams.for_hopper(record.params))
    if args.drake:
        document["drake_agreement"] = {"n": confirmation.n, "agreement": confirmation.agreement}
    return document


@cli_physics.reports_crashes
def main(argv=None) -> int:
    ap = arguments()
    args = ap.parse_args(argv)
    record = checked_plan(ap, args)
    print_margins(record)
    document = drawn(args, record)
    if args.out:
        from drakeslip.jobs.runner import write_json

        write_json(args.out, document)
        print(f"wrote {args.out}")
    if args.plot:
        from verification.plots import noise_scale, robustness_figure

        k = noise_scale(document["noise"])
        noise = f"realistic*{k:g}" if k is not None else "custom profile"
        title = f"{record.planner} plan {args.plan.name}, noise {noise}"
        print(f"figure: {robustness_figure(document, args.plot, title)}")
    return cli.OK


if __name__ == "__main__":
    sys.exit(main())
