"""Time the fast and the Drake step maps side by side, in one process, on the same random hops.

    python3 examples/bench_backends.py --cases 30 --seed 0

Each random hop is timed on the fast step map alone (best of --repeats calls), in a batch of leg angles as a
planner expands a node (best of --repeats, per angle), and on Drake (one call); the medians are printed.

Exit status: 0 when the timings ran, 2 for a usage error, 3 a simulation crashed (one line naming what failed:
drakeslip/jobs/cli.py).
"""
from __future__ import annotations

import sys

from drakeslip.jobs import cli
from drakeslip import cli_physics
from drakeslip.terrain import TERRAIN_FAMILIES, check_families

N_ANGLES = 30  # the batch: this many leg angles from each apex, as a planner expands a node


@cli_physics.reports_crashes
def main(argv=None) -> int:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--cases", type=cli.positive_int, default=30, help="random hops timed on both backends")
    ap.add_argument("--seed", type=cli.non_negative_int, default=0, help="seed of the random hops")
    ap.add_argument("--families", type=cli.names, default="step,ditch",
                    help=f"terrain families, comma-separated, from {','.join(sorted(TERRAIN_FAMILIES))}")
    ap.add_argument("--repeats", type=cli.positive_int, default=20,
                    help="fast-backend repetitions per case (the best is kept)")
    args = ap.parse_args(argv)
    try:
        check_families(args.families)
    except ValueError as error:
        ap.error(f"--families: {error}")

    import numpy as np

    import drakeslip as ds
    from verification.backend_agreement import best_time, draw_cases

    params = ds.SlipParams()
    families = ",".join(args.families)
    cases = draw_cases(args.cases, args.seed, tuple(args.families), params)
    terrains = [case.terrain() for case in cases]
    angles = np.linspace(-params.max_leg_angle, params.max_leg_angle, N_ANGLES)
    ds.step_batch(cases[0].apex, angles, terrains[0], params)  # load the compiled kernel before timing

    single, batch, drake = [], [], []
    for case, terrain in zip(cases, terrains):
        single.append(best_time(lambda: ds.step(case.apex, case.leg_angle, terrain, params), args.repeats))
        batch.append(best_time(lambda: ds.step_batch(case.apex, angles, terrain, params), args.repeats) / N_ANGLES)
        drake.append(best_time(lambda: ds.step(case.apex, case.leg_angle, terrain, params, backend="drake"), 1))
    single_us, batch_us, drake_us = (np.median(t) * 1e6 for t in (single, batch, drake))
    print(f"{args.cases} random hops ({families}), median time per step:")
    print(f"  fast, one step per call      {single_us:10.1f} us   Drake / fast = {drake_us / single_us:8.0f}x")
    print(f"  fast, batch of {N_ANGLES} angles     {batch_us:10.1f} us   Drake / fast = {drake_us / batch_us:8.0f}x")
    print(f"  drake                        {drake_us:10.1f} us")
    return cli.OK


if __name__ == "__main__":
    sys.exit(main())
