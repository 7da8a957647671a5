"""Check a saved plan on the Drake hybrid simulator: print its certificate (margins) or its counterexample.

Exit status: 0 certified, 1 counterexample (the first failure and the trace up to it), 2 unreadable plan file.

    python3 examples/verify_plan.py --plan out/plan.json --mode auto --json out/check.json
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from drakeslip.files import atomic_write
from planners.plan_io import load_plan
from verification.plan_check import MODES, check_plan


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plan", type=Path, required=True, help="plan file (drakeslip-plan/1 JSON)")
    parser.add_argument("--mode", choices=MODES, default="auto",
                        help="angles: leg angles open-loop; footholds: through the controller; auto: angles when "
                             "the plan has them all (default auto)")
    parser.add_argument("--json", type=Path, help="also write the certificate or counterexample here")
    args = parser.parse_args(argv)
    try:
        record = load_plan(args.plan)
        result = check_plan(record, args.mode)
    except (OSError, ValueError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    print(f"{record.planner} plan, {len(record.footholds)} footholds, start apex "
          f"({record.apex.x:g}, {record.apex.z:g}, {record.apex.xdot:g})")
    print(result.format())
    if args.json:
        with atomic_write(args.json, "w") as f:
            json.dump(result.to_dict(), f, indent=1, allow_nan=False)
    return 0 if result.ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
