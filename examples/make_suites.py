"""Write the paper's test suites: 15 terrains x 10 initial apex states = 150 cases, friction 0.8, goal 10 m.

    python examples/make_suites.py                       # the committed suites/ditch.json and suites/step.json
    python examples/make_suites.py --seed 5000 --families ditch,step,mixed --out-dir out/fresh   # fresh ones
"""
from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from planners.suite import COMMITTED_SEEDS, PAPER_TERRAINS, make_suite, save_suite


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--families", default="ditch,step", help="comma-separated: ditch, step, mixed")
    ap.add_argument("--seed", type=int, default=None,
                    help="base terrain seed (terrain i uses seed + 1000 * family index + i); "
                         "default: the committed suites' seeds")
    ap.add_argument("--terrains", type=int, default=PAPER_TERRAINS)
    ap.add_argument("--out-dir", default="suites")
    args = ap.parse_args(argv)
    print("reproduce with: python " + " ".join(shlex.quote(a) for a in [sys.argv[0]] + (argv or sys.argv[1:])))
    for k, family in enumerate(args.families.split(",")):
        seed = COMMITTED_SEEDS[family] if args.seed is None else args.seed + 1000 * k
        suite = make_suite(family, seed, n_terrains=args.terrains,
                           name=family if args.seed is None else f"{family}-{seed}")
        path = Path(args.out_dir) / f"{suite.name}.json"
        save_suite(suite, path)
        print(f"wrote {path}: {len(suite.cases)} cases, terrain seeds {seed}..{seed + args.terrains - 1}")


if __name__ == "__main__":
    main()
