"""Compare the fast and the Drake step maps on random hops over generated terrain and print the report.

    python3 examples/backend_agreement.py --cases 200 --seed 0 --families step,ditch
"""
import argparse

import drakeslip as ds
from verification.backend_agreement import compare_backends


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=100, help="number of random hops (default 100)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the random cases (default 0)")
    parser.add_argument("--families", default="step",
                        help=f"comma-separated terrain families from {sorted(ds.TERRAIN_FAMILIES)} (default step)")
    parser.add_argument("--tolerance", type=float, default=2e-3, help="foothold / apex tolerance in m (default 2e-3)")
    args = parser.parse_args()
    families = tuple(f.strip() for f in args.families.split(",") if f.strip())
    try:
        report = compare_backends(args.cases, args.seed, families, tolerance=args.tolerance)
    except ValueError as error:  # an unknown terrain family
        parser.error(str(error))
    print(report.format())


if __name__ == "__main__":
    main()
