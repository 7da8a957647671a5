"""Compare the fast and the Drake step maps on random hops over generated terrain and print the report.

    python3 examples/backend_agreement.py --cases 200 --seed 0 --families step,ditch
    python3 examples/backend_agreement.py --cases 1000 --families gaps     # the spatial hopper on height maps

Each random hop runs on both backends; the report counts the cases whose outcome differs (ok, or which failure)
and those where both succeed but the foothold or the next apex differ by more than --tolerance, and lists them.
--hopper runs the hops of another hopper (its apexes start above the ground by its leg length). Height-map families
(gaps, stones, stairs, blocks, course) compare the spatial hopper's step maps (verification/backend_agreement3d.py).

A near-tie (a guard grazed within one integration step) can fall either way on two integrators, so a few
outcome disagreements are expected; --max-disagreement sets how many are tolerated.

Exit status: 0 when the backends agree (outcomes within --max-disagreement, every shared success within --tolerance), 1
when they do not, 2 for a usage error, 3 a simulation crashed (one line naming what failed: drakeslip/jobs/cli.py).
"""
from __future__ import annotations

import sys

from drakeslip.jobs import cli
from drakeslip import cli_physics
from drakeslip.spatial.families import HEIGHT_MAP_FAMILIES, check_height_map_families
from drakeslip.terrain import TERRAIN_FAMILIES, check_families

TOLERANCE = {"planar": 2e-3, "height map": 1e-6}   # [m] the default --tolerance of each kind of family


@cli_physics.reports_crashes
def main(argv=None) -> int:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--cases", type=cli.positive_int, default=100, help="number of random hops")
    ap.add_argument("--seed", type=cli.non_negative_int, default=0, help="seed of the random hops")
    ap.add_argument("--families", type=cli.names, default="step",
                    help=f"terrain families, comma-separated, all from {','.join(sorted(TERRAIN_FAMILIES))} (planar) "
                         f"or all from {','.join(sorted(HEIGHT_MAP_FAMILIES))} (height maps)")
    cli_physics.add_hopper_argument(ap)
    ap.add_argument("--tolerance", type=cli.positive, default=None,
                    help="foothold / next-apex deviation [m] beyond which two successful hops disagree (default "
                         f"{TOLERANCE['planar']:g} on planar families, {TOLERANCE['height map']:g} on height maps)")
    ap.add_argument("--max-disagreement", type=cli.probability, default=0.01,
                    help="largest share of cases whose outcomes may differ (near-ties)")
    args = ap.parse_args(argv)
    spatial = all(name in HEIGHT_MAP_FAMILIES for name in args.families)
    try:
        (check_height_map_families if spatial else check_families)(args.families)
    except ValueError as error:
        ap.error(f"--families: {error}")
    tolerance = args.tolerance or TOLERANCE["height map" if spatial else "planar"]
    params = None if args.hopper is None else args.hopper.params
    if spatial:
        from verification.backend_agreement3d import compare_backends3d as compare
    else:
        from verification.backend_agreement import compare_backends as compare
    report = compare(args.cases, args.seed, tuple(args.families), params, tolerance=tolerance)
    print(report.format())
    agree = report.disagreement_rate <= args.max_disagreement and not report.beyond_tolerance
    return cli.OK if agree else cli.FAILED


if __name__ == "__main__":
    sys.exit(main())
