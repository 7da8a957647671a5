"""Simulate a SLIP hopper over generated terrain in Drake and draw what happened.

At every apex a small lookahead picks the leg angle: a grid of angles is stepped with the fast batched step
map, each success is stepped once more over the same grid, and the angle that survives two hops (with
neighbours that survive too) and keeps the speed closest to the nominal speed is commanded. The hops
themselves run in Drake's simulator.

    python3 examples/hop.py --terrain step --seed 3 --out out/hop.png --anim out/hop.gif --html out/hop.html

--html writes a Meshcat replay (one HTML file, opens offline) with the lookahead's predicted footholds and
apexes beside what Drake did. --hopper takes a hopper file or folder, --terrain a family (drawn for the hopper as
examples/make_suites.py --hopper draws it) or a terrain file (a height profile, drakeslip/terrain_file.py); --z and
--xdot left out are the paper's 0.75 m above the ground and 1.5 m/s in the hopper's units.

Exit status: 0 every hop completed, 1 one failed or the lookahead found no leg angle before --hops hops, 2 a usage
or input error, 3 a simulation crashed (one line naming what failed: drakeslip/jobs/cli.py).
"""
from __future__ import annotations

import math
import sys

from drakeslip.jobs import cli  # before numpy: a Ctrl-C while it loads is one line (drakeslip/jobs/cli.py)
from drakeslip import cli_physics

import numpy as np

import drakeslip as ds
from drakeslip.bounds import POSITION, SPEED

N_ANGLES = 41  # lookahead grid over +-atan(mu)
SURVIVAL_WEIGHT = 0.5  # preference for angles whose next apex leaves many safe choices


class TwoHopLookahead:
    """Leg-angle policy ``(apex, hop) -> angle | None`` that looks two hops ahead with the fast step map."""

    def __init__(self, terrain: ds.Terrain, params: ds.SlipParams, nominal_speed: float):
        self.terrain, self.params, self.nominal_speed = terrain, params, nominal_speed
        self.angles = np.linspace(-params.max_leg_angle, params.max_leg_angle, N_ANGLES)
        self.warnings: dict[int, str] = {}
        self.predicted: dict[int, ds.StepResult] = {}  # the fast step map's hop for each commanded angle

    def __call__(self, apex: ds.ApexState, hop: int) -> float | None:
        angle = self.choose(apex, hop)
        if angle is not None:
            self.predicted[hop] = ds.step(apex, angle, self.terrain, self.params)
        return angle

    def choose(self, apex: ds.ApexState, hop: int) -> float | None:
        angles, v = self.angles, self.nominal_speed
        first = ds.step_batch(apex, angles, self.terrain, self.params)
        ok = np.flatnonzero(first.ok)
        if ok.size == 0:
            self.warnings[hop] = "no leg angle survives the next hop"
            return None
        nxt = np.column_stack([first.next_x[ok], first.next_z[ok], first.next_xdot[ok]])
        second = ds.step_batch(np.repeat(nxt, angles.size, axis=0), np.tile(angles, ok.size), self.terrain,
                               self.params)
        ok2 = second.ok.reshape(ok.size, angles.size)
        speed2 = np.where(ok2, second.next_xdot.reshape(ok.size, angles.size), np.inf)
        survival = np.zeros(angles.size)
        survival[ok] = ok2.mean(axis=1)
        safe = survival > 0
        # Prefer angles whose grid neighbours are safe too: the choice then has margin on every side.
        robust = safe & np.r_[False, safe[:-1]] & np.r_[safe[1:], False]
        candidates = np.flatnonzero(robust if robust.any() else safe)
        if candidates.size == 0:
            self.warnings[hop] = "no leg angle survives two hops; taking the best one-hop survivor"
            return float(angles[ok[np.argmin(np.abs(first.next_xdot[ok] - v))]])
        row = {j: i for i, j in enumerate(ok)}
        cost = [abs(first.next_xdot[j] - v) + np.min(np.abs(speed2[row[j]] - v)) - SURVIVAL_WEIGHT * survival[j]
                for j in candidates]
        return float(angles[candidates[int(np.argmin(cost))]])


def report(result, policy: TwoHopLookahead, start: ds.ApexState, hops: int) -> None:
    """Each hop, then the outcome: ok only when all ``hops`` hops were completed."""
    apexes = [start] + result.apexes
    touchdowns = [e for e in result.events if e.kind == "touchdown"]
    terrain = result.terrain
    for hop, angle in enumerate(result.leg_angles):
        a = apexes[hop]
        line = (f"hop {hop + 1:2d}: apex x={a.x:6.3f} z={a.z:6.3f} (ground {terrain.height_at(a.x):+.3f}) "
                f"xdot={a.xdot:5.2f}  angle {math.degrees(angle):+6.1f} deg")
        if hop < len(touchdowns):
            foot = touchdowns[hop].foot
            line += f"  foothold x={foot[0]:6.3f} on {terrain.height_at(foot[0]):+.3f}"
        print(line)
        if hop in policy.warnings:
            print(f"        note: {policy.warnings[hop]}")
    if result.failure is not None:
        e = result.failure_event
        print(f"outcome: FAILED with {result.failure.name} at t={e.time:.3f} s, body at x={e.state[0]:.3f} "
              f"z={e.state[1]:.3f}")
    else:
        done, travelled = len(result.apexes), f"{apexes[-1].x - start.x:.2f} m travelled"
        if done < hops:   # the lookahead found no leg angle to command
            print(f"outcome: FAILED, stopped after {done} of {hops} hops, {travelled}: "
                  f"{policy.warnings[len(result.leg_angles)]}")
        else:
            print(f"outcome: ok, {done} hops, {travelled}")


def arguments() -> cli.ArgumentParser:
    ap = cli.ArgumentParser(__doc__)
    cli_physics.add_hopper_argument(ap)
    families = ["flat", *sorted(ds.TERRAIN_FAMILIES)]
    ap.add_argument("--terrain", type=cli_physics.terrain_or_family(*families), default="step",
                    help=f"terrain family ({', '.join(families)}) or terrain file (a height profile)")
    ap.add_argument("--seed", type=cli.non_negative_int, default=0, help="terrain seed")
    ap.add_argument("--hops", type=cli.positive_int, default=10, help="number of hops to simulate")
    ap.add_argument("--out", type=cli.output_file(".png", ".pdf", ".svg"), required=True, help="figure to write")
    ap.add_argument("--anim", type=cli.output_file(".gif"), default=None, help="also write an animation (GIF)")
    ap.add_argument("--html", type=cli.output_file(".html"), default=None,
                    help="also write a Meshcat replay (self-contained HTML)")
    ap.add_argument("--x0", type=cli_physics.physical(POSITION), default=0.0, help="start apex x [m]")
    ap.add_argument("--z", type=cli_physics.physical(POSITION), default=None,
                    help="start apex height, absolute [m] (default: 0.75 m above the ground, in the hopper's units)")
    ap.add_argument("--xdot", type=cli_physics.physical(SPEED, positive=True), default=None,
                    help="start apex speed [m/s], also the lookahead's nominal speed (default: 1.5, in the hopper's "
                         "units)")
    return ap


def checked_inputs(ap: cli.ArgumentParser, args):
    """(the hopper's parameters, the terrain, the start apex), or one line and exit status 2 for a start off the
    terrain's solid ground or out of bounds; ``args.terrain`` names a terrain file's path afterwards."""
    from drakeslip.state import check_start
    from drakeslip.terrain_file import scaled_terrain
    from drakeslip.units import PAPER, units_of
    from planners.formats.suite_draw import check_solid_start

    params = ds.SlipParams() if args.hopper is None else args.hopper.params
    units = units_of(params)
    if isinstance(args.terrain, cli_physics.TerrainFile):
        terrain, args.terrain = args.terrain.terrain, f"file {args.terrain.path}"
    elif args.terrain == "flat":
        terrain = ds.Terrain.flat() if units.length == 1.0 else scaled_terrain(ds.Terrain.flat(), units.length)
    elif params.with_friction(PAPER.friction) == PAPER:
        terrain = ds.TERRAIN_FAMILIES[args.terrain](args.seed)
    else:
        from planners.formats.suite_draw import hopper_terrain, suite_scales

        terrain = hopper_terrain(args.terrain, args.seed, suite_scales(params))
    try:
        check_solid_start(terrain, args.x0)   # as plan_and_hop.py refuses it
    except ValueError as error:
        ap.error(f"--x0: {error}")
    z = terrain.height_at(args.x0) + 0.75 * units.length if args.z is None else args.z
    try:
        start = check_start((args.x0, z, 1.5 * units.speed if args.xdot is None else args.xdot), terrain, params,
                            "the start apex")
    except ValueError as error:
        ap.error(str(error))
    return params, terrain, start


def draw(result, policy: TwoHopLookahead, args) -> None:
    """The figure, and the animation and the Meshcat replay when asked for."""
    from drakeslip.viz import animate, plot_trajectory

    args.out.parent.mkdir(parents=True, exist_ok=True)
    ax = plot_trajectory(result)
    ax.figure.savefig(args.out, dpi=150)
    print(f"figure: {args.out}")
    if args.anim:
        args.anim.parent.mkdir(parents=True, exist_ok=True)
        frames = animate(result, args.anim)
        print(f"animation: {args.anim} ({frames} frames)")
    if args.html:
        from drakeslip.meshcat_replay import write_replay

        predicted = [policy.predicted[hop] for hop in sorted(policy.predicted)]
        write_replay(result, args.html, planned_footholds=[p.touchdown_x for p in predicted if p.ok],
                     predicted_apexes=[p.next_apex for p in predicted if p.ok],
                     title=f"hop.py: {args.terrain} terrain, seed {args.seed}")
        print(f"replay: {args.html}")


@cli_physics.reports_crashes
def main(argv=None) -> int:
    ap = arguments()
    args = ap.parse_args(argv)
    params, terrain, start = checked_inputs(ap, args)
    policy = TwoHopLookahead(terrain, params, nominal_speed=start.xdot)
    print(f"{args.terrain} terrain (seed {args.seed}), start apex {tuple(start)}, up to {args.hops} hops in Drake")
    result = ds.simulate(start, policy, terrain, params, max_hops=args.hops)
    report(result, policy, start, args.hops)
    draw(result, policy, args)
    return cli.FAILED if result.failure is not None or len(result.apexes) < args.hops else cli.OK


if __name__ == "__main__":
    sys.exit(main())
