"""Plan footsteps over rough terrain and hop there: a planner in the receding-horizon loop, the first footholds
of each plan executed by the learned controller on the Drake hybrid simulator, replanning until the goal.

    python3 examples/plan_and_hop.py --terrain mixed --seed 3 --out out/plan_and_hop.png
    python3 examples/plan_and_hop.py --hopper my_hopper.json --terrain my_ground.csv --html out/replay.html
    python3 examples/plan_and_hop.py --terrain stones --seed 3 --goal 10,0 --out out/stones.png --html out/stones.html

--hopper takes a hopper file or a hopper folder (examples/train_hopper.py; its planners read the folder's weights)
and --terrain a terrain family, drawn for the hopper as examples/make_suites.py --hopper draws it, or a terrain
file (a height profile: drakeslip/terrain_file.py). --start-x, --speed, --height and --goal, when given, are taken
as given [m, m/s]; left out, they are the paper's start (x = 0, 2 m/s, 0.9 m above the ground) and course (10 m)
made the hopper's, on a terrain file without ground at x = 0 a start one leg length onto its first solid stretch
and a goal at most one leg length before its end (planners/formats/suite_draw.py, ``one_case``).

By default the robot is an imperfect one and the planner keeps margins for it: the `realistic` noise profile
(drakeslip/noise.py: the apex it is told is off by 5 mm and 2 cm/s, the leg by 0.005 rad, its spring, mass and
friction are not the model's, the terrain map is off by 1 cm; sizes of the paper's hopper, scaled to another's)
and the robust Step-space preset `step@robust`, replanning at every apex. `--planner step --noise none --executed 3`
is the paper's setting on a perfect robot.

Writes a figure of the terrain, the body path, the leg at every touchdown and liftoff, the planned and the executed
footholds; --html also writes a Meshcat replay of the run (self-contained HTML, the camera following the hopper: the
executed footholds against the planned ones, the plans' predicted apexes, the failure marked and named). With
--backend multibody both show the robot (drakeslip/multibody/replay.py; on a height map the spatial robot,
drakeslip/spatial/multibody/replay.py).

On a height map (--terrain a height-map family, drawn from --seed at --difficulty, or an .npz or .asc height-map file:
drakeslip/spatial/heightmap.py) the spatial hopper hops toward the point --goal X,Y on Drake (or on the fast step map,
--backend fast; or the spatial robot, --backend multibody) in the map loop (planners/spatial_loop.py,
verification/map_run.py): on a perfect robot (--noise in its 3D form), the `step` planner by default. The figure is the
map from above and the profile along the path, with the planned and the executed footholds and the goal; --html replays
the run in 3D.

Exit status: 0 the hopper reached the goal, 1 it did not (no plan, or a failed hop), 2 a usage or input error,
3 a simulation crashed (one line naming what failed: drakeslip/jobs/cli.py).
"""
from __future__ import annotations

import sys
from dataclasses import asdict

from drakeslip.jobs import cli
from drakeslip import cli_physics
from drakeslip.bounds import FRICTION, POSITION, SPEED
from drakeslip.terrain import TERRAIN_FAMILIES
from planners.formats.suite_draw import DEMO_COURSE, DEMO_HEIGHT, DEMO_SPEED
from planners.closed_loop import executed_plans
from planners.replanning import EXECUTED_PER_PLAN
from drakeslip.noise import PROFILES, describe
from planners.registry import check_label, loop_settings
from verification import map_run

FIGURE = (".png", ".pdf", ".svg")
PROFILE_PLANNER, PROFILE_NOISE = "step@robust", "realistic"   # the defaults on a profile (module doc)


def arguments() -> cli.ArgumentParser:
    ap = cli.ArgumentParser(__doc__)
    cli_physics.add_hopper_argument(ap)
    profiles = sorted(TERRAIN_FAMILIES)
    ap.add_argument("--terrain", type=map_run.ground_argument(cli_physics.terrain_or_family(*profiles), profiles),
                    default="mixed", help=f"terrain family ({', '.join(profiles)}), height-map family "
                                          f"({', '.join(map_run.HEIGHT_MAP_FAMILIES)}: the spatial hopper), terrain "
                                          "file (a height profile) or height-map file (.npz or .asc)")
    ap.add_argument("--seed", type=cli.non_negative_int, default=3,
                    help="terrain seed (of a terrain or height-map family)")
    ap.add_argument("--difficulty", type=cli.probability, default=None,
                    help="difficulty in [0, 1] of a height-map family's draw "
                         f"(default: {map_run.DEFAULT_DIFFICULTY:g})")
    ap.add_argument("--planner", default=None, help=f"planner label (a name, a preset or NAME@VARIANT) (default: "
                                                    f"{PROFILE_PLANNER}; {map_run.MAP_PLANNER} on a height map)")
    ap.add_argument("--noise", type=cli_physics.noise_profile, default=None,
                    help=f"noise profile of the robot: {', '.join(PROFILES)}, or NAME*K (drakeslip/noise.py) "
                         f"(default: {PROFILE_NOISE}; none on a height map, where it applies in its 3D form)")
    ap.add_argument("--noise-seed", type=cli.non_negative_int, default=0, help="seed of the noise draws")
    ap.add_argument("--executed", type=cli.positive_int, default=None,
                    help="footholds of each plan executed before replanning (default: the planner preset's "
                         f"period, else {EXECUTED_PER_PLAN}, the paper's; 1 for the spatial robot on a height map)")
    ap.add_argument("--start-x", type=cli_physics.physical(POSITION), default=None,
                    help="initial apex x [m] (default: 0, or one leg length onto a terrain file's first solid ground; "
                         "on a height map -1, made the hopper's)")
    ap.add_argument("--speed", type=cli_physics.physical(SPEED, positive=True), default=None,
                    help=f"initial apex forward speed [m/s] (default: {DEMO_SPEED:g}, made the hopper's)")
    ap.add_argument("--height", type=cli_physics.physical(POSITION, positive=True), default=None,
                    help=f"initial apex height above the ground [m] (default: {DEMO_HEIGHT:g}, made the hopper's)")
    ap.add_argument("--goal", type=map_run.goal_argument, default=None,
                    help=f"goal x [m], on the terrain (default: {DEMO_COURSE:g} m from the start, made the hopper's); "
                         "on a height map a point X,Y (default: 10,0, made the hopper's)")
    ap.add_argument("--friction", type=cli_physics.physical(FRICTION), default=None,
                    help="Coulomb friction coefficient at the foot (default: the hopper's, 0.8 for the paper's)")
    ap.add_argument("--out", type=cli.output_file(*FIGURE), default="out/plan_and_hop.png", help="figure to write")
    ap.add_argument("--html", type=cli.output_file(".html"), default=None,
                    help="also write a Meshcat replay of the run (self-contained HTML)")
    ap.add_argument("--backend", choices=("drake", "multibody", "fast"), default="drake",
                    help="what hops: the SLIP on Drake, or the multibody robot (drakeslip/multibody) in one "
                         "closed-loop Diagram, planning for the template fitted to it; on a height map also the "
                         "spatial SLIP's fast step map (fast)")
    return ap


def profile_arguments(ap: cli.ArgumentParser, args) -> None:
    """The flags as a profile takes them: its default planner and noise, the goal an x; one line and exit status 2
    for what is a height map's only."""
    if args.goal is not None and len(args.goal) == 2:
        ap.error(f"--goal: a point X,Y is a height map's goal; on a terrain profile the goal is an x, got "
                 f"{','.join(f'{g:g}' for g in args.goal)}")
    if args.difficulty is not None:
        ap.error("--difficulty draws a height-map family; the terrain families of profiles have none")
    if args.backend == "fast":
        ap.error("--backend fast hops on height maps only here; on a profile use drake or multibody")
    args.goal = None if args.goal is None else args.goal[0]
    args.planner = args.planner or PROFILE_PLANNER
    args.noise = args.noise or cli_physics.noise_profile(PROFILE_NOISE)


def checked_inputs(ap: cli.ArgumentParser, args):
    """(the hopper, its one-case suite, the parameters the robot runs with, the controller, the planner wrapped in
    a PlanRecorder), or one line and exit status 2 for a bad label, hopper, terrain, start or weights file."""
    from drakeslip import StepLengthController
    from drakeslip.hopper_file import paper_hopper
    from planners.closed_loop import PlanRecorder
    from planners.formats.suite_draw import one_case
    from planners.registry import hopper_specs, make_planners

    hopper = args.hopper or paper_hopper()
    try:
        check_label(args.planner)
        ground = args.terrain if isinstance(args.terrain, str) else args.terrain.terrain
        suite = one_case(ground, args.seed, hopper, args.speed, args.height, args.goal, args.start_x)
        params = hopper.params.with_friction(args.friction or hopper.params.friction)
        controller = StepLengthController.load_default()
        specs = hopper_specs({args.planner: None}, hopper)
        planner = PlanRecorder(make_planners(specs, controller)[args.planner])
    except (OSError, ValueError) as error:
        ap.error(str(error))
    return hopper, suite, params, controller, planner


def report(result: dict, hopper, executed: int, args) -> None:
    """Each plan of the run, then its outcome."""
    for i, p in enumerate(result["plans"]):
        steps = " ".join(f"{x:.2f}" for x in p["footholds"])
        print(f"plan {i}: from x={p['apex'][0]:.2f}, {p['ode_calls']} ODE calls, {1e3 * p['t_plan_s']:.1f} ms: "
              f"{steps or p['message']}")
    outcome = "reached the goal" if result["success"] else f"failed: {result['failure']}"
    noise = "no noise" if args.noise.silent else f"noise {describe(args.noise)}"
    print(f"{args.planner} for hopper {hopper.name} (replanning every {executed} hops, {noise}) on "
          f"{where(args)}: "
          f"{outcome} at x = {result['final_x']:.2f} after {len(result['plans'])} plans")


@cli_physics.reports_crashes
def main(argv=None) -> int:
    ap = arguments()
    args = ap.parse_args(argv)
    if isinstance(args.terrain, map_run.MapGround):
        return map_run.hop_on_map(ap, args, argv)
    profile_arguments(ap, args)
    hopper, suite, params, controller, planner = checked_inputs(ap, args)
    cli.announce(argv)

    from drakeslip import SlipParams
    from planners.closed_loop import ClosedLoopConfig, run_case
    from planners.formats.suite import Case

    case = Case("demo", suite.cases[0].terrain, suite.cases[0].apex)   # the id seeds the noise draws
    terrain, apex, args.goal, args.start_x = case.terrain, case.apex, suite.goal_x, case.apex.x
    loop = loop_settings(args.planner)
    executed = args.executed or loop.get("executed_per_plan", EXECUTED_PER_PLAN)
    config = ClosedLoopConfig(**{**loop, "executed_per_plan": executed}, noise=args.noise, seed=args.noise_seed)
    if args.backend == "multibody":
        return hop_robot(planner, terrain, apex, params, config, args)
    result = run_case(planner, controller, case, args.goal, params, config)
    report(result, hopper, executed, args)
    sim = replay(result, apex, terrain, SlipParams(**result.get("executed_params", asdict(params))))
    write_figure(sim, result, terrain, args)
    if args.html:
        write_html(sim, result, planner.plans, args)
    return cli.OK if result["success"] else cli.FAILED


def hop_robot(planner, terrain, apex, params, config, args) -> int:
    """The multibody robot in its closed-loop Diagram: print the plans, draw the run, write the replay."""
    from dataclasses import replace
    from types import SimpleNamespace

    from drakeslip.multibody.fit import fitted_template, template_for
    from drakeslip.multibody.replay import plot_robot_run, write_robot_replay
    from drakeslip.multibody.robot import RobotParams
    from planners.drake_system import run_closed_loop

    robot, template = RobotParams.for_hopper(params), fitted_template()   # the hopper's robot, its fitted template
    template = params if template is None else template_for(params, template)
    result = run_closed_loop(planner, SimpleNamespace(id="demo", terrain=terrain, apex=apex), args.goal, template,
                             replace(config, robot=robot), trajectory=True)
    log = result["log"]
    for i, p in enumerate(result["plans"]):
        print(f"plan {i}: from x={p['apex'][0]:.2f}: {' '.join(f'{x:.2f}' for x in p['footholds']) or p['message']}")
    outcome = "reached the goal" if result["success"] else f"failed: {result['failure']} ({result['what']})"
    print(f"{args.planner} on the multibody robot, {where(args)}: {outcome} at x = "
          f"{result['final_x']:.2f}; largest body pitch {result['max_pitch']:.3f} rad; {result['simulated_s']:.1f} s "
          f"simulated in {result['wall_s']:.1f} s")
    save_figure(plot_robot_run(log, terrain, robot), result, terrain, args,
                f"{args.planner} on the multibody robot, {where(args)}: {outcome}")
    if args.html:
        planned, predicted = executed_plans(planner.plans, result["plans"])
        ending = "reached the goal" if result["success"] else f"failed ({result['failure']})"
        write_robot_replay(log, terrain, args.html, planned, predicted,
                           title=f"plan_and_hop.py: {args.planner} on the multibody robot, {where(args)}, {ending}",
                           robot=robot)
        print(f"replay: {args.html}")
    return cli.OK if result["success"] else cli.FAILED


def replay(result: dict, apex, terrain, params):
    """One logged Drake run of the leg angles the loop's hops reached, on the hopper that ran them, for the figure
    (the loop ran the same hops in pieces, each from the apex the last one reached)."""
    from drakeslip.rollout import rollout

    angles = [a for p in result["plans"] for a in p.get("leg_angles", [])]
    if not angles:
        return None
    return rollout(apex, terrain, params, leg_angles=angles, log=True).simulation


def where(args) -> str:
    """'mixed terrain seed 3' or 'terrain file ground.csv'."""
    return (f"{args.terrain} terrain seed {args.seed}" if isinstance(args.terrain, str)
            else f"terrain file {args.terrain.path}")


def write_figure(sim, result, terrain, args):
    from drakeslip.viz import new_axes, plot_terrain, plot_trajectory

    if sim is not None:
        ax = plot_trajectory(sim)
        terrain = sim.terrain
    else:  # no foothold was commanded: the terrain alone
        ax = new_axes((12, 3.5))
        plot_terrain(ax, terrain, (args.start_x - 1.0, args.goal + 1.0))
    outcome = "reached the goal" if result["success"] else f"failed ({result['failure']})"
    noise = "perfect robot" if args.noise.silent else f"noise {describe(args.noise)}"
    save_figure(ax, result, terrain, args,
                f"{args.planner} planner + controller on Drake ({noise}), {where(args)}: {outcome}")


def save_figure(ax, result, terrain, args, title):
    """Add the executed plans' footholds and the goal to the run's figure ``ax``, title it and save it."""
    import numpy as np

    planned = np.array([x for p in result["plans"] for x in p["footholds"][:len(p.get("executed", []))]])
    if planned.size:
        ax.plot(planned, terrain.height_at(planned) + 0.04, "v", color="#2a7ab0", ms=6, mec="black",
                label="planned footholds", zorder=6)
    ax.axvline(args.goal, color="green", ls=":", lw=1.5, label="goal")
    ax.set_title(title)
    ax.figure.legends.clear()
    ax.figure.legend(loc="outside lower center", fontsize=8, ncols=8, frameon=False)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    ax.figure.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


def write_html(sim, result, plans, args):
    """The Meshcat replay: every executed plan's commanded footholds and predicted apexes over the run (a plan of
    the heuristic or lstm planner predicts none: its apexes are NaN rows)."""
    import numpy as np

    from drakeslip.meshcat_replay import write_replay

    if sim is None:
        print("no replay: no foothold was commanded")
        return
    planned, predicted = executed_plans(plans, result["plans"])
    outcome = "reached the goal" if result["success"] else f"failed ({result['failure']})"
    write_replay(sim, args.html, planned_footholds=planned,
                 predicted_apexes=[a for a in predicted if np.all(np.isfinite(a))],
                 title=f"plan_and_hop.py: {args.planner} on {where(args)}, {outcome}")
    print(f"replay: {args.html}")


if __name__ == "__main__":
    sys.exit(main())
