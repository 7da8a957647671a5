"""Write the paper's test suites: 15 terrains x 10 initial apex states = 150 cases, friction 0.8, goal 10 m.

    python3 examples/make_suites.py                       # the committed suites/ditch.json and suites/step.json
    python3 examples/make_suites.py --seed 5000 --families ditch,step,mixed --out out/fresh   # fresh ones
    python3 examples/make_suites.py --families step --seed 90000 --speeds 0.8,1.5,2.2 --heights 0.65,0.75 \
        --out out/low     # low-energy starts (the oracle's hard cases)
    python3 examples/make_suites.py --hopper my_hopper.json --seed 7000 --out out/mine   # drawn for a hopper
    python3 examples/make_suites.py --hopper my_hopper.json --terrains my_profiles/ --out out/mine  # your terrains

--hopper draws each suite for a hopper file (or folder): the paper's problems made the same kind of problem for it
(planners/formats/suite_draw.py: ditch widths, step heights, start heights and speeds, the course, in its units;
--speeds and --heights are then the paper hopper's, made the hopper's). --terrains DIR makes one suite, OUT/DIR.json,
of every terrain file in the folder (.csv, .txt: height profiles or heights per cell, drakeslip/terrain_file.py) x
every start (--speeds x --heights, in m/s and m above the ground as given; default: the paper's made the hopper's),
from x = --start-x to the goal --goal (default: the paper's -1 m and 11 m course, made the hopper's).

Each family's suite is written to OUT/NAME.json: NAME is the family for the committed seeds, FAMILY-SEED for
fresh ones (terrain i of the k-th family uses seed SEED + 1000 k + i).

The height-map families (gaps, stones, stairs, blocks, course: drakeslip/spatial/families.py) write one height-map
suite each (format drakeslip-map-suite/1, planners/formats/map_suite.py) to OUT/FAMILY-SEED.json: --terrains maps
(15) drawn from seeds SEED, SEED + 1, ..., map i of n at difficulty i / (n - 1) (every difficulty from 0 to 1), each
x the starts (--speeds x --heights above the ground at x = -1 m, y = 0, heading +x), goal (10, 0) m; --hopper draws
them in its units (the maps with length = its leg / 0.5 m, the starts as the planar suites'). They need --seed.
Planar and height-map families may be mixed in one call: each suite is its own kind, and the planar ones get the
seeds they get without the others (k counts the planar families only).

    python3 examples/make_suites.py --families gaps,stones,stairs,blocks,course --seed 58000 --out out/maps

Exit status: 0 when the suites were written, 2 for a usage or input error (a malformed terrain file: one line naming
its row).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from drakeslip.jobs import cli
from drakeslip import cli_physics
from drakeslip.bounds import POSITION, SPEED
from drakeslip.spatial.families import HEIGHT_MAP_FAMILIES
from drakeslip.terrain import TERRAIN_FAMILIES
from planners.formats.suite import COMMITTED_SEEDS, PAPER_HEIGHTS, PAPER_SPEEDS, PAPER_TERRAINS

# The most terrains (or height maps) a drawn suite may have: terrain i of the k-th planar family uses seed
# SEED + 1000 k + i, so a 1001st would take the next family's first seed; a map suite holds all its maps in memory
# (about a megabyte each: 1000 take 4 s and 1 GB to draw). The paper's suites have 15, the docs' at most 15.
MAX_TERRAINS = 1000
# The most starts per terrain (--speeds x --heights): a suite holds terrains x starts cases, so MAX_TERRAINS x this
# is 100,000 cases, about 20 s and 1.2 GB to draw; the paper's suites have 10 (5 speeds x 2 heights), the docs' at
# most 10. Without a bound two lists of thousands of numbers would ask for billions of cases.
MAX_STARTS = 100


def main(argv=None) -> int:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--families", type=cli.names, default="ditch,step",
                    help=f"families, comma-separated: terrain profiles from {','.join(sorted(TERRAIN_FAMILIES))}, "
                         f"height maps from {','.join(HEIGHT_MAP_FAMILIES)}")
    ap.add_argument("--seed", type=cli.non_negative_int, default=None,
                    help="base terrain seed (terrain i of the k-th family uses seed + 1000 k + i); "
                         "none: the committed suites' seeds, " + ", ".join(f"{f} {s}" for f, s in
                                                                           COMMITTED_SEEDS.items()))
    ap.add_argument("--terrains", type=count_or_folder, default=PAPER_TERRAINS,
                    help=f"terrains (or height maps) per suite, 1 to {MAX_TERRAINS}, or a folder of terrain files "
                         "making one suite")
    cli_physics.add_hopper_argument(ap)
    ap.add_argument("--speeds", type=cli.numbers(None, cli_physics.physical(SPEED, positive=True)), default=None,
                    help=f"apex speeds of the starts, m/s, comma-separated (default: {PAPER_SPEEDS}); with --heights "
                         f"at most {MAX_STARTS} starts")
    ap.add_argument("--heights", type=cli.numbers(None, cli_physics.physical(POSITION, positive=True)), default=None,
                    help=f"apex heights of the starts, m, comma-separated (default: {PAPER_HEIGHTS})")
    ap.add_argument("--start-x", type=cli_physics.physical(POSITION), default=None,
                    help="with --terrains DIR: x of the starts [m] (default: -1, made the hopper's)")
    ap.add_argument("--goal", type=cli_physics.physical(POSITION), default=None,
                    help="with --terrains DIR: goal x [m] (default: 10, the course made the hopper's)")
    ap.add_argument("--out", type=cli.output_folder, default="suites", help="folder the suite files are written to")
    args = ap.parse_args(argv)
    starts = (len(args.speeds or PAPER_SPEEDS), len(args.heights or PAPER_HEIGHTS))
    if starts[0] * starts[1] > MAX_STARTS:
        ap.error(f"--speeds x --heights: {starts[0]} x {starts[1]} = {starts[0] * starts[1]} starts per terrain, more "
                 f"than the {MAX_STARTS} a suite may have")
    if not isinstance(args.terrains, Path):
        if args.start_x is not None or args.goal is not None:
            ap.error("--start-x and --goal go with --terrains DIR (a drawn suite's are the paper's, made the hopper's)")
        return draw(ap, args, argv)

    from planners.formats.suite import save_suite
    from planners.formats.suite_draw import suite_from_terrains

    try:
        suite = suite_from_terrains(args.terrains, args.hopper, args.speeds, args.heights, args.start_x, args.goal)
    except (OSError, ValueError) as error:
        ap.error(str(error))
    path = args.out / f"{suite.name}.json"
    ap.check_outputs(args, [("--out", path)])
    make_folder(ap, args.out)
    cli.announce(argv)
    save_suite(suite, path)
    print(f"wrote {path}: {len(suite.cases)} cases, start x = {suite.cases[0].apex.x:g}, goal x = {suite.goal_x:g}")
    return cli.OK


def count_or_folder(text: str):
    """An argument type: a count of terrains per suite (1 to MAX_TERRAINS) or a folder of terrain files."""
    if text.isdigit():
        return cli.integer(1, MAX_TERRAINS)(text)
    if not Path(text).is_dir():
        raise argparse.ArgumentTypeError(f"{text!r} is neither a count of terrains nor a folder of terrain files")
    return Path(text)


def draw(ap, args, argv) -> int:
    """The suites of --families drawn for --hopper (the paper's: make_suite's and make_map_suite's)."""
    args.speeds, args.heights = args.speeds or PAPER_SPEEDS, args.heights or PAPER_HEIGHTS
    planar = [family for family in args.families if family in TERRAIN_FAMILIES]
    unknown = [family for family in args.families if family not in TERRAIN_FAMILIES | HEIGHT_MAP_FAMILIES]
    if unknown:
        ap.error(f"--families: unknown terrain families {unknown}; choose from {sorted(TERRAIN_FAMILIES)} (profiles) "
                 f"or {list(HEIGHT_MAP_FAMILIES)} (height maps)")
    if args.seed is None and not set(args.families) <= set(COMMITTED_SEEDS):
        ap.error(f"--families {sorted(set(args.families) - set(COMMITTED_SEEDS))} have no committed suite; "
                 "give --seed")
    # a planar family's seed is SEED + 1000 k (k among the planar families); every map family draws from SEED
    seeds = {family: (COMMITTED_SEEDS[family] if args.seed is None else args.seed + 1000 * planar.index(family))
             if family in TERRAIN_FAMILIES else args.seed for family in args.families}
    names = {family: family if args.seed is None else f"{family}-{seed}" for family, seed in seeds.items()}
    ap.check_outputs(args, [("--out", args.out / f"{name}.json") for name in names.values()])

    from planners.formats.map_suite import make_map_suite, save_map_suite
    from planners.formats.suite import save_suite
    from planners.formats.suite_draw import draw_suite

    try:   # every suite drawn before any is written: a start outside the bounds is refused first
        suites = [draw_suite(family, seed, args.hopper, n_terrains=args.terrains, speeds=args.speeds,
                             heights=args.heights, name=names[family]) if family in TERRAIN_FAMILIES else
                  make_map_suite(family, seed, args.terrains, args.speeds, args.heights, hopper=args.hopper,
                                 name=names[family]) for family, seed in seeds.items()]
    except ValueError as error:
        ap.error(str(error))
    make_folder(ap, args.out)
    cli.announce(argv)
    for suite, (family, seed) in zip(suites, seeds.items()):
        path = args.out / f"{suite.name}.json"
        if family in TERRAIN_FAMILIES:
            save_suite(suite, path)
            print(f"wrote {path}: {len(suite.cases)} cases, terrain seeds {seed}..{seed + args.terrains - 1}")
        else:
            save_map_suite(suite, path)
            print(f"wrote {path}: {len(suite.cases)} cases, {family} maps of seeds {seed}..{seed + args.terrains - 1} "
                  f"at difficulty 0..{1 if args.terrains > 1 else 0}, goal ({suite.goal[0]:g}, {suite.goal[1]:g})")
    return cli.OK


def make_folder(ap, folder: Path) -> None:
    """Make the --out folder once every suite is drawn and checked, so a refused call leaves none behind; one line
    and exit status 2 when it cannot be made (``cli.output_folder`` checked it could, at parsing)."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        ap.error(f"--out: cannot make the folder {str(folder)!r}: {error.strerror}")


if __name__ == "__main__":
    sys.exit(main())
