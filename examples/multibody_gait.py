"""The multibody hopper's gait check: hops on flat ground in place and at speed, with the largest body attitude.

    python3 examples/multibody_gait.py --speeds 0,1,2,3 --hops 100
    python3 examples/multibody_gait.py --robot spatial --speeds 0,1,2,3 --headings 0,45,90 --hops 100

The controller places the foot by Raibert's rule for each speed (no footholds) and holds an apex 0.62 m high; the
largest pitch (and, on the spatial robot, roll) is printed over all hops and after the first SETTLING_HOPS (the
start, body level at an apex already at speed, is not the gait's own rhythm). The spatial robot (``--robot
spatial``) hops each speed in each heading, then turns 90 degrees to the left at each nonzero speed (the wanted
heading turning 22.5 degrees a hop) and takes a ``--push`` [N s] to the left of its heading at an apex at each
speed up to 2 m/s: the hops until the velocity is the wanted one again (within 0.25 m/s and 5 degrees, from then on)
are printed. Exit status: 0 when every run hops its hops with no failure, every turn is done in under 10 hops and
every push undone within 5; 1 otherwise; 2 on bad input; 3 a simulation crashed (one line naming what failed:
drakeslip/jobs/cli.py).
"""
from __future__ import annotations

import argparse
import sys
import time

from drakeslip.jobs import cli
from drakeslip import cli_physics

OK, FAILED = cli.OK, cli.FAILED
SETTLING_HOPS = 5   # the hops from the start (body level at an apex already at speed) to the gait's own rhythm
TURN_HOPS = 10   # a turn of 90 degrees is done in fewer hops than this
PUSH_HOPS = 5    # a push is undone within this many hops
PUSH_SPEEDS = 2.0   # [m/s] the spatial robot is pushed at each of --speeds up to this


def _speeds(text: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"speeds must be numbers separated by commas, got {text!r}") from None
    if not values or any(not 0.0 <= v <= 4.0 for v in values):
        raise argparse.ArgumentTypeError(f"speeds must lie in [0, 4] m/s, got {text!r}")
    return values


def _headings(text: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"headings must be numbers separated by commas, got {text!r}") from None
    if not values or any(not -360.0 <= v <= 360.0 for v in values):
        raise argparse.ArgumentTypeError(f"headings must lie in [-360, 360] degrees, got {text!r}")
    return values


def _impulse(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0.0 <= value <= 100.0:
        raise argparse.ArgumentTypeError(f"push must be an impulse in [0, 100] N s, got {text!r}")
    return value


def _hops(text: str) -> int:
    if not text.isdigit() or int(text) < 1:
        raise argparse.ArgumentTypeError(f"hops must be a positive integer, got {text!r}")
    return int(text)


@cli_physics.reports_crashes
def main(argv=None) -> int:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--speeds", type=_speeds, default="0,1,2,3", help="forward speeds [m/s], comma-separated")
    ap.add_argument("--hops", type=_hops, default=100, help="hops at each speed")
    ap.add_argument("--robot", choices=("planar", "spatial"), default="planar",
                    help="the planar robot (drakeslip/multibody) or the spatial one (drakeslip/spatial/multibody)")
    ap.add_argument("--headings", type=_headings, default="0,45,90",
                    help="headings [degrees from x toward y], comma-separated (spatial robot)")
    ap.add_argument("--push", type=_impulse, default=20.0, help="the push's impulse [N s] (spatial robot)")
    args = ap.parse_args(argv)
    if args.robot == "spatial":
        return OK if _spatial(args) else FAILED

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


def _outcome(log, hops: int) -> str:
    if log.failure is not None:
        return f"{log.failure.mode.name}: {log.failure.what}"
    return "ok" if len(log.apexes) >= hops else "too few hops"


def _spatial(args) -> bool:
    """The spatial robot's checks (see the module doc); True when all pass."""
    import math

    from drakeslip.spatial.multibody.gait import hop_flat, push, turn

    ok = True
    for speed in args.speeds:
        for heading in args.headings:
            velocity = (speed * math.cos(math.radians(heading)), speed * math.sin(math.radians(heading)))
            start = time.perf_counter()
            log = hop_flat(lambda k: velocity, args.hops)
            wall = time.perf_counter() - start
            outcome = _outcome(log, args.hops)
            ok &= outcome == "ok"
            roll, pitch = log.max_attitude()
            settled = log.max_attitude(SETTLING_HOPS)
            last = log.apexes[-1] if log.apexes else None
            simulated = last[0] if last else 0.0
            print(f"speed {speed:.1f} m/s heading {heading:g} deg: {len(log.apexes)} hops, {outcome}; largest |roll| "
                  f"{roll:.3f}, |pitch| {pitch:.3f} rad ({settled[0]:.3f}, {settled[1]:.3f} after the first "
                  f"{SETTLING_HOPS} hops)" + (f"; last apex z {last[3]:.3f} m, velocity ({last[4]:.2f}, {last[5]:.2f}) "
                                             f"m/s, yaw {last[6]:+.2f} rad; {wall:.1f} s wall, "
                                             f"{simulated / wall:.1f}x real time" if last else ""))
    for speed in (s for s in args.speeds if s > 0):
        log, hops = turn(speed)
        done = hops is not None and hops < TURN_HOPS
        ok &= done
        roll, pitch = log.max_attitude()
        print(f"turn of 90 deg at {speed:.1f} m/s: {_outcome(log, len(log.apexes))}; "
              + (f"done in {hops} hops" if hops is not None else "not done") +
              f"; largest |roll| {roll:.3f}, |pitch| {pitch:.3f} rad")
    for speed in (s for s in args.speeds if s <= PUSH_SPEEDS):
        log, hops = push(speed, 0.0, args.push)
        done = hops is not None and hops <= PUSH_HOPS
        ok &= done
        roll, pitch = log.max_attitude()
        print(f"push of {args.push:g} N s to the left at {speed:.1f} m/s: {_outcome(log, len(log.apexes))}; "
              + (f"undone in {hops} hops" if hops is not None else "not undone") +
              f"; largest |roll| {roll:.3f}, |pitch| {pitch:.3f} rad")
    return ok


if __name__ == "__main__":
    sys.exit(main())
