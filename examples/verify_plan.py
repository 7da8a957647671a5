"""Check a saved plan on the Drake hybrid simulator: print its certificate (margins) or its counterexample.

    python3 examples/verify_plan.py --plan out/plan.json --mode auto --out out/check.json

Exit status: 0 certified, 1 counterexample (the first failure and the trace up to it), 2 a usage error or a
malformed plan file.
"""
from __future__ import annotations

import sys

from drakeslip.jobs import cli

MODES = ("angles", "footholds", "auto")


def main(argv=None) -> int:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--plan", type=cli.input_file, required=True, help="plan file (drakeslip-plan/1 JSON)")
    ap.add_argument("--mode", choices=MODES, default="auto",
                    help="angles: the plan's leg angles open loop; footholds: its footholds through the controller; "
                         "auto: angles when the plan has them all")
    ap.add_argument("--out", type=cli.output_file(".json"), default=None,
                    help="also write the certificate or counterexample here (JSON)")
    args = ap.parse_args(argv)

    from drakeslip.jobs.runner import write_json
    from planners.formats.plan import load_plan
    from verification.plan_check import check_plan

    try:
        record = load_plan(args.plan)
    except (OSError, ValueError) as error:
        ap.error(str(error))
    print(f"{record.planner} plan, {len(record.footholds)} footholds, start apex "
          f"({record.apex.x:g}, {record.apex.z:g}, {record.apex.xdot:g})")
    try:
        result = check_plan(record, args.mode)
    except ValueError as error:  # e.g. mode angles on a plan without every angle
        ap.error(str(error))
    print(result.format())
    if args.out:
        write_json(args.out, result.to_dict())
    return cli.OK if result.ok else cli.FAILED


if __name__ == "__main__":
    sys.exit(main())
