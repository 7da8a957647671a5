"""examples/plan_and_hop.py on a height map: the spatial hopper planned for and hopped over a map family's draw
or a height-map file, in the receding-horizon loop of ``planners.spatial_loop``.

The script's flags keep their meaning where the spatial loop has one: --start-x, --height and --speed set the start apex
(at y = 0, heading +x; left out: x = -1 m, 0.9 m above the ground, 2 m/s, each made the hopper's as a map suite makes
it, ``planners.formats.map_suite``), --goal is a point X,Y (a single number is (X, 0); left out: the map suites' goal
(10, 0) made the hopper's, at most one leg length before a map file's end), --seed and --difficulty draw a family's map.
With --backend multibody the spatial robot (``drakeslip.spatial.multibody``) hops in the map loop as one Diagram
(``planners.spatial_robot_loop``), the figure and the replay showing the robot's own run. What the script does not do
on a map is refused in one line before any work: a planner that plans on profiles only or with options the map search
does not take (the default here is ``step``). A noise profile applies in its 3D form (the default is none here).

Everything that loads pydrake, numba or matplotlib is imported inside the functions, so the script's --help stays
fast.
"""
from __future__ import annotations

import argparse
import math
from dataclasses import dataclass
from pathlib import Path

from drakeslip.bounds import POSITION
from drakeslip.jobs import cli
from drakeslip.spatial.families import HEIGHT_MAP_FAMILIES
from drakeslip.spatial.heightmap import MAP_SUFFIXES, load_height_map

DEFAULT_DIFFICULTY = 0.5          # of a family's draw when --difficulty is left out: the middle of [0, 1]
MAP_PLANNER = "step"              # the planners' default on maps: the robust preset plans on profiles only


@dataclass(frozen=True)
class MapGround:
    """--terrain naming a height map: a family of ``HEIGHT_MAP_FAMILIES`` (``path`` None, drawn once the hopper is
    known) or a height-map file, read at parsing (``height_map``)."""

    name: str
    path: Path | None = None
    height_map: object = None

    def input_files(self) -> tuple:   # a map file is never written over (drakeslip.jobs.file_args)
        return () if self.path is None else (self.path,)


def ground_argument(profile_type, profile_families):
    """An argument type for --terrain: a height-map family or file (a MapGround), else what ``profile_type`` (the
    script's planar type, for ``profile_families`` and profile files) makes of it."""
    def parse(text: str):
        if text in HEIGHT_MAP_FAMILIES:
            return MapGround(text)
        if Path(text).suffix.lower() in MAP_SUFFIXES:
            try:
                return MapGround(text, Path(text), load_height_map(text))
            except ValueError as error:
                raise argparse.ArgumentTypeError(str(error)) from None
        if text not in profile_families and not Path(text).is_file():
            raise argparse.ArgumentTypeError(
                f"{text!r} is neither a terrain family ({', '.join(profile_families)}), a height-map family "
                f"({', '.join(HEIGHT_MAP_FAMILIES)}) nor a terrain or height-map file")
        return profile_type(text)
    return parse


def goal_argument(text: str) -> tuple:
    """An argument type for --goal: X (one number) or X,Y (a point, for a height map), each a position."""
    parts = text.split(",")
    if len(parts) > 2:
        raise argparse.ArgumentTypeError(f"must be X or X,Y, got {text!r}")
    position = cli.number(POSITION.low, POSITION.high)
    return tuple(position(p.strip()) for p in parts)


def refuse(ap, args) -> None:
    """One line and exit status 2 for a flag the map loop does not run (module doc)."""
    if args.html and args.backend == "fast":
        ap.error("--html: the fast backend logs no trajectory to replay; use --backend drake")
    if args.difficulty is not None and args.terrain.path is not None:
        ap.error(f"--difficulty draws a height-map family; {args.terrain.name} is a file")


def start_and_goal(height_map, params, scales, args) -> tuple:
    """(the start apex (x, y, z, xdot, ydot), the goal (x, y)) of the module doc for the hopper ``params`` and the
    demo start's ``scales`` (``suite_scales``); ValueError for a start off the map's cells or over a hole, or a
    goal not ahead of it."""
    from planners.formats.map_suite import MAP_GOAL, START_Y, check_map_start
    from planners.formats.suite import START_X
    from planners.formats.suite_draw import DEMO_HEIGHT, DEMO_SPEED

    x_min, x_max, y_min, y_max = height_map.extent
    x = START_X * scales.length if args.start_x is None else args.start_x
    y = START_Y * scales.length
    if not (x_min <= x < x_max and y_min <= y < y_max):
        raise ValueError(f"the start (x, y) = ({x:g}, {y:g}) is not over the map, which covers x in [{x_min:g}, "
                         f"{x_max:g}) and y in [{y_min:g}, {y_max:g}) m")
    ground = height_map.height_at(x, y)
    if math.isnan(ground):
        raise ValueError(f"the start (x, y) = ({x:g}, {y:g}) is over a hole of the map")
    above = DEMO_HEIGHT * scales.length * scales.start_heights[0] if args.height is None else args.height
    speed = DEMO_SPEED * scales.speed if args.speed is None else args.speed
    apex = check_map_start((x, y, ground + above, speed, 0.0), height_map, params, "the start apex")
    if args.goal is None:
        goal = (min(MAP_GOAL[0] * scales.length, x_max - params.leg_length), MAP_GOAL[1] * scales.length)
    else:
        goal = (args.goal[0], args.goal[1] if len(args.goal) == 2 else 0.0)
    if goal[0] <= x:
        raise ValueError(f"the goal ({goal[0]:g}, {goal[1]:g}) must lie ahead of the start x={x:g} "
                         "(the hopper starts along +x)")
    return apex, goal


def checked_map_inputs(ap, args) -> tuple:
    """(the hopper, the case, its parameters, the planner, the loop's settings), or one line and exit status 2."""
    from drakeslip.hopper_file import paper_hopper
    from drakeslip.spatial.families import height_map_family
    from planners.formats.suite_draw import DEMO_HEIGHT, DEMO_SPEED, suite_scales
    from planners.registry import hopper_specs, loop_settings, make_planners
    from planners.replanning import EXECUTED_PER_PLAN, ClosedLoopConfig
    from planners.spatial_loop import MapCase

    refuse(ap, args)
    hopper = args.hopper or paper_hopper()
    try:
        scales = suite_scales(hopper.params, (DEMO_HEIGHT,), (DEMO_SPEED,))
        height_map = args.terrain.height_map
        if height_map is None:   # a family's map, drawn in the hopper's lengths as a map suite draws it
            difficulty = DEFAULT_DIFFICULTY if args.difficulty is None else args.difficulty
            height_map = height_map_family(args.terrain.name)(args.seed, difficulty, scales.length)
        apex, goal = start_and_goal(height_map, hopper.params, scales, args)
        params = hopper.params.with_friction(args.friction or hopper.params.friction)
    except ValueError as error:
        ap.error(str(error))
    try:
        planner = make_planners(hopper_specs({args.planner: None}, hopper))[args.planner]
        # a plan to where the hopper already is costs nothing, and a planner that does not plan on maps (or not
        # with its preset's options) says so here rather than at the first apex
        planner.plan(apex, height_map, apex[:2], params)
    except ValueError as error:
        ap.error(f"--planner {args.planner}: {error}")
    # the spatial robot replans at every apex: it is not where the template's hops would have taken it
    robot_period = 1 if args.backend == "multibody" else None
    executed = args.executed or robot_period or loop_settings(args.planner).get("executed_per_plan",
                                                                                 EXECUTED_PER_PLAN)
    config = ClosedLoopConfig(executed_per_plan=executed, backend=args.backend, seed=args.noise_seed,
                              **({} if args.noise is None else {"noise": args.noise}))
    return hopper, MapCase("demo", height_map, apex, goal), params, planner, config


def hop_on_map(ap, args, argv) -> int:
    """The script on a height map: check, plan and hop, print the plans and the outcome, draw, replay."""
    from planners.spatial_loop import run_map_case

    args.planner = args.planner or MAP_PLANNER
    hopper, case, params, planner, config = checked_map_inputs(ap, args)
    cli.announce(argv)
    if config.backend == "multibody":
        return hop_robot_on_map(case, params, planner, config, hopper, args)
    result, sim = run_map_case(planner, case, params, config)
    report(result, hopper, config, args)
    write_figure(case, result, sim, args)
    if args.html:
        from drakeslip.spatial.meshcat_replay import write_replay3d

        write_replay3d(sim, args.html, planned_footholds=commanded(result),
                       title=f"plan_and_hop.py: {args.planner} on {where(args)}, {outcome(result)}")
        print(f"replay: {args.html}")
    return cli.OK if result["success"] else cli.FAILED


# many parameters: the checked inputs of ``checked_map_inputs`` and the script's arguments
def hop_robot_on_map(case, params, planner, config, hopper, args) -> int:
    """The spatial robot in the map loop: print the plans and the outcome, draw the run, write the replay."""
    from drakeslip.spatial.multibody.replay import plot_spatial_robot_run, write_spatial_robot_replay
    from planners.spatial_robot_loop import run_map_case_on_robot

    result = run_map_case_on_robot(planner, case, params, config, trajectory=True)
    report(result, hopper, config, args)
    log, robot = result["log"], result["robot"]
    roll, pitch = log.max_attitude()
    print(f"the spatial robot: {len(log.touchdowns)} touchdowns, largest roll {roll:.2f} rad, pitch {pitch:.2f} rad, "
          f"{result['simulated_s']:.1f} s simulated in {result['wall_s']:.1f} s")
    title = f"{args.planner} planner on the spatial robot, {where(args)}: {outcome(result)}"
    figure = plot_spatial_robot_run(log, case.terrain, commanded(result), title, robot, goal=case.goal)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")
    if args.html:
        write_spatial_robot_replay(log, case.terrain, args.html, commanded(result), f"plan_and_hop.py: {title}", robot)
        print(f"replay: {args.html}")
    return cli.OK if result["success"] else cli.FAILED


def where(args) -> str:
    """'stones height map seed 3, difficulty 0.5' or 'height map file ground.npz'."""
    if args.terrain.path is not None:
        return f"height map file {args.terrain.path}"
    difficulty = DEFAULT_DIFFICULTY if args.difficulty is None else args.difficulty
    return f"{args.terrain.name} height map seed {args.seed}, difficulty {difficulty:g}"


def outcome(result: dict) -> str:
    return "reached the goal" if result["success"] else f"failed ({result['failure']})"


def commanded(result: dict) -> list:
    """(x, y, z) of every foothold the loop flew: each plan's first ones, as planned."""
    return [f for p in result["plans"] for f in p["executed"]]


def report(result: dict, hopper, config, args) -> None:
    """Each plan of the run, then its outcome: hops, planning calls, mean planning time."""
    for i, p in enumerate(result["plans"]):
        steps = " ".join(f"({f[0]:.2f}, {f[1]:.2f})" for f in p["footholds"])
        print(f"plan {i}: from (x, y) = ({p['apex'][0]:.2f}, {p['apex'][1]:.2f}), {p['ode_calls']} ODE calls, "
              f"{1e3 * p['t_plan_s']:.1f} ms: {steps or p['message']}")
    plans = result["plans"]
    mean_ms = 1e3 * sum(p["t_plan_s"] for p in plans) / max(len(plans), 1)
    x, y = result["final"]
    print(f"{args.planner} for hopper {hopper.name} on the spatial hopper ({config.backend}, replanning every "
          f"{config.executed_per_plan} hops), {where(args)}: {outcome(result)} at (x, y) = ({x:.2f}, {y:.2f}) after "
          f"{len(commanded(result))} hops, {len(plans)} planning calls, mean plan time {mean_ms:.1f} ms")


def write_figure(case, result: dict, sim, args) -> None:
    """Top view and side profile of the run: the map, the body's path, the planned and executed footholds, the
    goal (``drakeslip.spatial.viz``)."""
    from drakeslip.spatial.viz import plot_run3d, plot_simulation3d

    title = f"{args.planner} planner on the spatial hopper ({args.backend}), {where(args)}: {outcome(result)}"
    if sim is not None and sim.times.size:
        figure = plot_simulation3d(sim, commanded(result), case.goal)
        figure.axes[0].set_title(title)
    else:
        # no Drake trajectory (the fast backend, or no hop at all): the path through the apexes the loop planned
        # from, and the footholds it commanded; where the feet landed is not logged
        path = [p["apex"][:3] for p in result["plans"]] or [case.apex[:3]]
        figure = plot_run3d(case.terrain, path, [], commanded(result), None,
                            f"{title} (path through the plans' apexes)", goal=case.goal)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")
