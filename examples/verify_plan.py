"""Check a saved plan on the Drake hybrid simulator: certify the plan as written, or print a counterexample.

    python3 examples/verify_plan.py --plan out/plan.json --mode auto --out out/check.json

CERTIFIED means the Drake run completed every hop of the plan with no failure, touched down within --tolerance of
every planned foothold, reached every predicted apex within --tolerance (x and z in m, xdot in m/s), and reached
the plan's target; its margins say how far it stayed from each failure. Otherwise the counterexample names the
first place the run left the plan (a failure, a missed foothold, a missed apex, the target not reached), with
the hop, planned against actual, the state and hybrid state there, and the trace up to it.

--plot draws the Drake run over the terrain with the planned and actual footholds and the counterexample marked
(PNG); --html writes a Meshcat replay of it (self-contained HTML). --hopper checks the plan against a hopper file or
folder: a plan made for another hopper is refused in one line. --terrain checks it on the ground of a terrain file
(a measured height profile, drakeslip/terrain_file.py) instead of the plan file's.

A map plan (drakeslip-map-plan/1, examples/make_plan.py on a height-map suite) is checked on its own map: on the
spatial SLIP on Drake (--mode angles or footholds), or with --backend multibody on the spatial robot built for its
hopper, flying its footholds; --plot and --html then draw that run (the robot's own links in the replay). The
certificate and counterexample are verification/map_plan_check.py's; on Drake its margins are the friction to
spare, the spring travel left, the body's height above the map and the footholds' distance to the nearest edge.

Exit status: 0 certified, 1 counterexample, 2 a usage error or a malformed plan file (its fields disagree, or one
lies outside the physical bounds of drakeslip/bounds.py, such as a stiffness of 1e308: see
planners/formats/plan.py), refused in one line before the simulation starts, 3 no verdict: the simulation stopped
before the run left the plan or ended, in one line naming why (the integrator failed, NaN derivatives, or a hop
outlasted the simulator's limit, a TIMEOUT: drakeslip/jobs/cli.py).
"""
from __future__ import annotations

import math
import sys
from dataclasses import replace

from drakeslip.jobs import cli
from drakeslip import cli_physics
from verification.plan_check_options import MODES, TOLERANCE


def arguments() -> cli.ArgumentParser:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--plan", type=cli.input_file, required=True,
                    help="plan file (drakeslip-plan/2 or /1 JSON, or drakeslip-map-plan/1)")
    ap.add_argument("--mode", choices=MODES, default="auto",
                    help="angles: the plan's leg angles open loop; footholds: its footholds through the controller; "
                         "auto: angles when the plan has them all")
    cli_physics.add_hopper_argument(ap, default="the plan file's")
    ap.add_argument("--terrain", type=cli_physics.terrain_or_family(), default=None,
                    help="check the plan on this terrain file's ground instead of the plan file's")
    ap.add_argument("--tolerance", type=cli.positive, default=TOLERANCE,
                    help="how far [m, m/s] a touchdown or apex may be from the plan's")
    ap.add_argument("--out", type=cli.output_file(".json"), default=None,
                    help="also write the certificate or counterexample here (JSON)")
    ap.add_argument("--plot", type=cli.output_file(".png"), default=None,
                    help="also draw the Drake run, planned against actual, the counterexample marked (PNG)")
    ap.add_argument("--html", type=cli.output_file(".html"), default=None,
                    help="also write a Meshcat replay of the Drake run (self-contained HTML)")
    ap.add_argument("--backend", choices=("drake", "multibody"), default="drake",
                    help="what executes the plan: the SLIP on Drake, or the multibody robot (drakeslip/multibody; "
                         "drakeslip/spatial/multibody for a map plan) aiming at the plan's footholds (--mode is then "
                         "footholds; on a profile --plot and --html draw the SLIP)")
    return ap


def covering(terrain, record, path):
    """``terrain`` (a --terrain file's) if it covers the plan, from its start to its last foothold; else ValueError: a
    certificate on ground the file does not describe (past its ends a terrain extends flat) would certify another
    course than the user's."""
    low, high = min(record.apex.x, *record.footholds), max(record.apex.x, *record.footholds)
    if low < terrain.x0 or high >= terrain.x_end:
        raise ValueError(f"--terrain {path} covers x in [{terrain.x0:g}, {terrain.x_end:g}) m; the plan runs from "
                         f"x={low:g} to x={high:g} m: give a terrain that covers it")
    return terrain


def is_map_plan_file(ap: cli.ArgumentParser, path) -> bool:
    """Whether ``path`` holds a map plan (by its format); one line and exit status 2 for a file that is not JSON."""
    from drakeslip.jobs.files import read_json
    from planners.formats.map_plan import is_map_plan

    try:
        return is_map_plan(read_json(path, "plan file"))
    except (OSError, ValueError) as error:
        ap.error(str(error))


def checked_plan(ap: cli.ArgumentParser, args):
    """The plan file's record (on --terrain's ground when given), or one line and exit status 2 for flags that do
    not go together, a malformed plan file, another hopper's plan or a plan --mode cannot run."""
    if args.backend == "multibody" and (args.plot or args.html):
        ap.error("--plot and --html draw the SLIP's run: use them with --backend drake")

    from drakeslip.hopper_file import check_same_hopper
    from planners.formats.plan import load_plan

    try:
        record = load_plan(args.plan)
        if args.hopper is not None:
            check_same_hopper(args.hopper, record.params, f"plan file {args.plan}")
        if args.terrain is not None:
            record = replace(record, terrain=covering(args.terrain.terrain, record, args.terrain.path))
        if args.mode == "angles" and not all(abs(a) < 1.5707963 for a in record.leg_angles):
            raise ValueError(f"--mode angles needs every leg angle; {args.plan} has NaN ones: use --mode footholds")
    except (OSError, ValueError) as error:
        ap.error(str(error))
    return record


def checked_on_robot(record, args) -> int:
    """The plan's footholds aimed at by the multibody robot: the verdict printed (and written with --out)."""
    from drakeslip.jobs.runner import write_json
    from verification.provenance import provenance
    from verification.robot_check import check_plan_on_robot

    result = check_plan_on_robot(record, args.tolerance)
    print(result.format())
    if args.out:
        write_json(args.out, {**result.to_dict(), "plan": str(args.plan), "provenance": provenance()})
    return cli.OK if result.ok else cli.FAILED


def draw(result, record, args) -> None:
    """The figure (--plot) and the Meshcat replay (--html) of the Drake run, when asked for."""
    title = f"verify_plan.py: {record.planner} plan {args.plan.name}"
    if args.plot:
        from verification.plots import plan_check_figure

        print(f"figure: {plan_check_figure(result, record, result.simulation, args.plot, title)}")
    if args.html:
        from drakeslip.meshcat_replay import write_replay

        verdict = "certified" if result.ok else f"counterexample: {result.reason()}"
        write_replay(result.simulation, args.html, planned_footholds=list(record.footholds),
                     predicted_apexes=[a for a in record.apexes if all(map(math.isfinite, a))],
                     title=f"{title}, {result.mode}: {verdict}")
        print(f"replay: {args.html}")


def checked_map_plan(ap: cli.ArgumentParser, args):
    """The map plan file's record, or one line and exit status 2 for flags that do not go together, a malformed
    file, another hopper's plan or a plan --mode cannot run."""
    import numpy as np

    from drakeslip.hopper_file import check_same_hopper
    from planners.formats.map_plan import load_map_plan

    if args.terrain is not None:
        ap.error("--terrain takes a height profile: a map plan is checked on its own map")
    if args.backend == "multibody" and args.mode == "angles":
        ap.error("--backend multibody flies the plan's footholds: leave --mode out or give footholds")
    try:
        record = load_map_plan(args.plan)
        if args.hopper is not None:
            check_same_hopper(args.hopper, record.params, f"plan file {args.plan}")
    except (OSError, ValueError) as error:
        ap.error(str(error))
    if args.mode == "angles" and not np.all(np.isfinite(record.leg_angles)):
        ap.error(f"--mode angles needs every leg angle; {args.plan} has null ones: use --mode footholds")
    return record


def checked_on_map(record, args) -> int:
    """A map plan run on the spatial SLIP or robot (``verification.map_plan_check``): the verdict printed, written
    with --out, drawn with --plot and --html."""
    import numpy as np

    from drakeslip.jobs.runner import write_json
    from verification.map_plan_check import check_map_plan
    from verification.provenance import provenance

    mode = "footholds" if args.backend == "multibody" or args.mode == "footholds" or \
        (args.mode == "auto" and not np.all(np.isfinite(record.leg_angles))) else "angles"
    first, last = record.footholds[0], record.footholds[-1]
    print(f"{record.planner} plan on a height map, {len(record.footholds)} footholds from ({first[0]:g}, {first[1]:g}) "
          f"to ({last[0]:g}, {last[1]:g}), target ({record.target[0]:g}, {record.target[1]:g})")
    result = check_map_plan(record, mode, args.tolerance, args.backend)
    print(result.format())
    if args.out:
        write_json(args.out, {**result.to_dict(), "plan": str(args.plan), "hopper": record.hopper.to_record(),
                              "provenance": provenance()})
    on = "the robot" if args.backend == "multibody" else "Drake"
    verdict = "certified" if result.ok else f"counterexample at hop {result.hop} ({result.kind})"
    title = f"verify_plan.py: {record.planner} plan {args.plan.name} on {on}: {verdict}"
    if args.backend == "multibody":
        from drakeslip.spatial.multibody.replay import plot_spatial_robot_run, write_spatial_robot_replay
        from drakeslip.spatial.multibody.robot import SpatialRobotParams

        robot = SpatialRobotParams.for_hopper(record.params)
        if args.plot:
            plot_spatial_robot_run(result.run, record.height_map, record.footholds, title, robot,
                                   goal=record.goal).savefig(args.plot, dpi=110)
        if args.html:
            write_spatial_robot_replay(result.run, record.height_map, args.html, record.footholds, title, robot)
    else:
        from drakeslip.spatial.meshcat_replay import write_replay3d
        from drakeslip.spatial.viz import plot_simulation3d

        if args.plot:
            plot_simulation3d(result.run, record.footholds, record.goal, args.plot)
        if args.html:
            write_replay3d(result.run, args.html, record.footholds, title)
    for flag, path in (("figure", args.plot), ("replay", args.html)):
        if path:
            print(f"{flag}: {path}")
    return cli.OK if result.ok else cli.FAILED


@cli_physics.reports_crashes
def main(argv=None) -> int:
    ap = arguments()
    args = ap.parse_args(argv)
    if is_map_plan_file(ap, args.plan):
        return checked_on_map(checked_map_plan(ap, args), args)
    record = checked_plan(ap, args)
    print(f"{record.planner} plan, {len(record.footholds)} footholds to target x={record.target_x:g}, start apex "
          f"({record.apex.x:g}, {record.apex.z:g}, {record.apex.xdot:g})")
    if args.backend == "multibody":
        return checked_on_robot(record, args)

    from drakeslip.hopper_file import hopper_for
    from drakeslip.jobs.runner import write_json
    from verification.plan_check import check_plan
    from verification.provenance import provenance

    result = check_plan(record, args.mode, args.tolerance)
    print(result.format())
    if args.out:
        hopper = (record.hopper or hopper_for(record.params)).to_record()
        write_json(args.out, {**result.to_dict(), "plan": str(args.plan), "hopper": hopper,
                              "provenance": provenance()})
    draw(result, record, args)
    return cli.OK if result.ok else cli.FAILED


if __name__ == "__main__":
    sys.exit(main())
