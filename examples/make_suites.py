"""Write the paper's test suites: 15 terrains x 10 initial apex states = 150 cases, friction 0.8, goal 10 m.

    python3 examples/make_suites.py                       # the committed suites/ditch.json and suites/step.json
    python3 examples/make_suites.py --seed 5000 --families ditch,step,mixed --out out/fresh   # fresh ones
    python3 examples/make_suites.py --families step --seed 90000 --speeds 0.8,1.5,2.2 --heights 0.65,0.75 \
        --out out/low     # low-energy starts (the oracle's hard cases)

Each family's suite is written to OUT/NAME.json: NAME is the family for the committed seeds, FAMILY-SEED for
fresh ones (terrain i of the k-th family uses seed SEED + 1000 k + i).

Exit status: 0 when the suites were written, 2 for a usage error.
"""
from __future__ import annotations

import sys

from drakeslip.bounds import POSITION, SPEED
from drakeslip.terrain import TERRAIN_FAMILIES, check_families
from drakeslip.jobs import cli
from planners.formats.suite import COMMITTED_SEEDS, PAPER_HEIGHTS, PAPER_SPEEDS, PAPER_TERRAINS


def main(argv=None) -> int:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--families", type=cli.names, default="ditch,step",
                    help=f"terrain families, comma-separated, from {','.join(sorted(TERRAIN_FAMILIES))}")
    ap.add_argument("--seed", type=cli.non_negative_int, default=None,
                    help="base terrain seed (terrain i of the k-th family uses seed + 1000 k + i); "
                         "none: the committed suites' seeds, " + ", ".join(f"{f} {s}" for f, s in
                                                                           COMMITTED_SEEDS.items()))
    ap.add_argument("--terrains", type=cli.positive_int, default=PAPER_TERRAINS, help="terrains per suite")
    ap.add_argument("--speeds", type=cli.numbers(None, cli.physical(SPEED, positive=True)), default=PAPER_SPEEDS,
                    help="apex speeds of the starts, m/s, comma-separated (default: %(default)s)")
    ap.add_argument("--heights", type=cli.numbers(None, cli.physical(POSITION, positive=True)), default=PAPER_HEIGHTS,
                    help="apex heights of the starts, m, comma-separated (default: %(default)s)")
    ap.add_argument("--out", type=cli.output_folder, default="suites", help="folder the suite files are written to")
    args = ap.parse_args(argv)
    try:
        check_families(args.families)
    except ValueError as error:
        ap.error(f"--families: {error}")
    if args.seed is None and not set(args.families) <= set(COMMITTED_SEEDS):
        ap.error(f"--families {sorted(set(args.families) - set(COMMITTED_SEEDS))} have no committed suite; "
                 "give --seed")
    try:
        args.out.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        ap.error(f"--out: cannot make the folder {str(args.out)!r}: {error.strerror}")
    cli.announce(argv)

    from planners.formats.suite import make_suite, save_suite

    for k, family in enumerate(args.families):
        seed = COMMITTED_SEEDS[family] if args.seed is None else args.seed + 1000 * k
        suite = make_suite(family, seed, n_terrains=args.terrains, speeds=args.speeds, heights=args.heights,
                           name=family if args.seed is None else f"{family}-{seed}")
        path = args.out / f"{suite.name}.json"
        save_suite(suite, path)
        print(f"wrote {path}: {len(suite.cases)} cases, terrain seeds {seed}..{seed + args.terrains - 1}")
    return cli.OK


if __name__ == "__main__":
    sys.exit(main())
