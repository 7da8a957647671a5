"""The multibody hopper's gait check: hops on flat ground in place and at speed, with the largest body pitch.

    python3 examples/multibody_gait.py --speeds 0,1,2,3 --hops 100

The controller places the foot by Raibert's rule for each speed (no footholds) and holds the energy of an apex
0.62 m high; the largest pitch is printed over all hops and after the first SETTLING_HOPS (the start, body level
at an apex already at speed, is not the gait's own rhythm). Exit status: 0 when every speed hops --hops hops with
no failure, 1 otherwise, 2 on bad input,
3 a simulation crashed (one line naming what failed: drakeslip/jobs/cli.py).
"""
from __future__ import annotations

import argparse
import sys
import time

from drakeslip.jobs import cli
from drakeslip import cli_physics

OK, FAILED = cli.OK, cli.FAILED
SETTLING_HOPS = 5   # the hops from the start (body level at an apex already at speed) to the gait's own rhythm


def _speeds(text: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"speeds must be numbers separated by commas, got {text!r}") from None
    if not values or any(not 0.0 <= v <= 4.0 for v in values):
        raise argparse.ArgumentTypeError(f"speeds must lie in [0, 4] m/s, got {text!r}")
    return values


def _hops(text: str) -> int:
    if not text.isdigit() or int(text) < 1:
        raise argparse.ArgumentTypeError(f"hops must be a positive integer, got {text!r}")
    return int(text)


@cli_physics.reports_crashes
def main(argv=None) -> int:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--speeds", type=_speeds, default="0,1,2,3", help="forward speeds [m/s], comma-separated")
    ap.add_argument("--hops", type=_hops, default=100, help="hops at each speed")
    args = ap.parse_args(argv)

    from drakeslip.multibody.execute import hop_at_speed

    ok = True
    for speed in args.speeds:
        start = time.perf_counter()
        log = hop_at_speed(speed, args.hops)
        wall = time.perf_counter() - start
        last = log.apexes[-1] if log.apexes else None
        outcome = "ok" if log.failure is None and len(log.apexes) >= args.hops else \
            (f"{log.failure.mode.name}: {log.failure.what}" if log.failure else "too few hops")
        ok &= outcome == "ok"
        settled = max(log.hop_pitch[SETTLING_HOPS:], default=float("nan"))
        print(f"speed {speed:.1f} m/s: {len(log.apexes)} hops, {outcome}; largest |pitch| {log.max_pitch:.3f} rad "
              f"({settled:.3f} after the first {SETTLING_HOPS} hops); "
              f"last apex z {last.z:.3f} m, xdot {last.xdot:.2f} m/s; {wall:.1f} s wall" if last else
              f"speed {speed:.1f} m/s: no apex, {outcome}")
    return OK if ok else FAILED


if __name__ == "__main__":
    sys.exit(main())
