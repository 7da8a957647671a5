"""Success probability of a saved plan under start-apex and leg-angle (controller) noise, by Monte Carlo.

The draws run on the fast backend; ``--drake K`` reruns the first K of them on Drake and reports agreement.

    python3 examples/robustness.py --plan out/plan.json --samples 2000 --seed 0 --drake 10
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from planners.plan_io import load_plan
from verification.robustness import confirm_on_drake, success_probability


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plan", type=Path, required=True, help="plan file (drakeslip-plan/1 JSON)")
    parser.add_argument("--samples", type=int, default=1000, help="Monte Carlo draws (default 1000)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the draws (default 0)")
    parser.add_argument("--apex-noise", default="0.01,0.01,0.05",
                        help="standard deviations of the start apex x [m], z [m], xdot [m/s] (default 0.01,0.01,0.05)")
    parser.add_argument("--angle-noise", type=float, default=0.01,
                        help="standard deviation of every commanded leg angle [rad] (default 0.01, about 1 cm of "
                             "foothold)")
    parser.add_argument("--drake", type=int, default=0, metavar="K",
                        help="rerun the first K draws on Drake and report agreement (default 0)")
    args = parser.parse_args(argv)
    try:
        apex_noise = tuple(float(v) for v in args.apex_noise.split(","))
    except ValueError:
        parser.error(f"--apex-noise must be three comma-separated numbers, got {args.apex_noise!r}")
    if args.samples < 1 or not 0 <= args.drake <= args.samples:
        parser.error(f"need --samples >= 1 and 0 <= --drake <= --samples, got {args.samples} and {args.drake}")
    try:
        record = load_plan(args.plan)
    except (OSError, ValueError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    try:
        t0 = time.perf_counter()
        result = success_probability(record, args.samples, apex_noise, args.angle_noise, args.seed)
        seconds = time.perf_counter() - t0
    except ValueError as error:  # e.g. negative noise
        parser.error(str(error))
    print(f"{record.planner} plan, {len(record.footholds)} footholds; {seconds:.2f} s")
    print(result.format())
    if args.drake:
        t0 = time.perf_counter()
        confirmation = confirm_on_drake(result, args.drake)
        print(confirmation.format() + f" ({time.perf_counter() - t0:.1f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
