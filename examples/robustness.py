"""Success probability of a saved plan under start-apex and leg-angle (controller) noise, by Monte Carlo.

The draws run on the fast backend; ``--drake K`` reruns the first K of them on Drake and reports agreement.

    python3 examples/robustness.py --plan out/plan.json --samples 2000 --seed 0 --drake 10

Exit status: 0 when the draws ran, 2 for a usage or input error.
"""
from __future__ import annotations

import sys
import time

from drakeslip.jobs import cli


def main(argv=None) -> int:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--plan", type=cli.input_file, required=True, help="plan file (drakeslip-plan/1 JSON)")
    ap.add_argument("--samples", type=cli.positive_int, default=1000, help="Monte Carlo draws")
    ap.add_argument("--seed", type=cli.non_negative_int, default=0, help="seed of the draws")
    ap.add_argument("--apex-noise", type=cli.numbers(3, cli.non_negative), default="0.01,0.01,0.05",
                    help="standard deviations of the start apex x [m], z [m], xdot [m/s]")
    ap.add_argument("--angle-noise", type=cli.non_negative, default=0.01,
                    help="standard deviation of every commanded leg angle [rad] (0.01 rad is about 1 cm of foothold)")
    ap.add_argument("--drake", type=cli.non_negative_int, default=0, metavar="K",
                    help="rerun the first K draws on Drake and report agreement")
    args = ap.parse_args(argv)
    if args.drake > args.samples:
        ap.error(f"--drake {args.drake} is more than --samples {args.samples}")

    from planners.formats.plan import load_plan
    from verification.robustness import confirm_on_drake, success_probability

    try:
        record = load_plan(args.plan)
    except (OSError, ValueError) as error:
        ap.error(str(error))
    t0 = time.perf_counter()
    result = success_probability(record, args.samples, args.apex_noise, args.angle_noise, args.seed)
    print(f"{record.planner} plan, {len(record.footholds)} footholds; {time.perf_counter() - t0:.2f} s")
    print(result.format())
    if args.drake:
        t0 = time.perf_counter()
        confirmation = confirm_on_drake(result, args.drake)
        print(confirmation.format() + f" ({time.perf_counter() - t0:.1f} s)")
    return cli.OK


if __name__ == "__main__":
    sys.exit(main())
