"""Plan footsteps over rough terrain and hop there: the Step-space planner in a receding-horizon loop, each
plan's first 3 footholds executed by the learned controller on the Drake hybrid simulator, to the goal.

    python examples/plan_and_hop.py --terrain mixed --seed 3 --out out/plan_and_hop.png

Writes a figure of the terrain, the body path, the planned and the executed footholds.
"""
from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

import numpy as np

from drakeslip import ApexState, SlipParams, TERRAIN_FAMILIES
from drakeslip.controller import StepLengthController
from drakeslip.simulate import simulate
from planners import available, make
from planners.registry import takes
from planners.evaluation import EXECUTED_PER_PLAN, EvalConfig, run_case
from planners.suite import Case


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--terrain", default="mixed", choices=sorted(TERRAIN_FAMILIES))
    ap.add_argument("--seed", type=int, default=3, help="terrain seed")
    ap.add_argument("--planner", default="step", help=f"one of {available()}")
    ap.add_argument("--speed", type=float, default=2.0, help="initial apex forward speed [m/s]")
    ap.add_argument("--height", type=float, default=0.9, help="initial apex height above the ground [m]")
    ap.add_argument("--goal", type=float, default=10.0, help="goal x [m]")
    ap.add_argument("--friction", type=float, default=0.8)
    ap.add_argument("--out", default="out/plan_and_hop.png", help="figure to write")
    args = ap.parse_args(argv)
    if args.planner not in available():
        ap.error(f"unknown planner {args.planner!r}; known planners: {', '.join(available())}")
    print("reproduce with: python " + " ".join(shlex.quote(a) for a in [sys.argv[0]] + (argv or sys.argv[1:])))

    terrain = TERRAIN_FAMILIES[args.terrain](args.seed)
    params = SlipParams(friction=args.friction)
    apex = ApexState(0.0, terrain.height_at(0.0) + args.height, args.speed)
    controller = StepLengthController.load_default()
    planner = make(args.planner, **({"controller": controller} if takes(args.planner, "controller") else {}))
    result = run_case(planner, controller, Case("demo", terrain, apex), args.goal, params, EvalConfig())

    for i, p in enumerate(result["plans"]):
        steps = " ".join(f"{x:.2f}" for x in p["footholds"])
        print(f"plan {i}: from x={p['apex'][0]:.2f}, {p['ode_calls']} ODE calls, {1e3 * p['t_plan_s']:.1f} ms: "
              f"{steps or p['message']}")
    outcome = "reached the goal" if result["success"] else f"failed: {result['failure']}"
    print(f"{args.planner} on {args.terrain} seed {args.seed}: {outcome} at x = {result['final_x']:.2f} "
          f"after {len(result['plans'])} plans")

    # One logged Drake run of every commanded foothold, for the figure (the loop above ran it in pieces).
    commanded = [x for p in result["plans"] if "executed" in p for x in p["footholds"][:EXECUTED_PER_PLAN]]
    sim = simulate(apex, lambda a, hop: controller.leg_angle(a, commanded[hop], terrain) if hop < len(commanded)
                   else None, terrain, params, max_hops=max(len(commanded), 1))
    write_figure(sim, result, args)


def write_figure(sim, result, args):
    import matplotlib
    matplotlib.use("Agg")
    from drakeslip.viz import plot_trajectory

    ax = plot_trajectory(sim)
    planned = np.array([x for p in result["plans"] for x in p["footholds"][:EXECUTED_PER_PLAN]])
    if planned.size:
        ax.plot(planned, sim.terrain.height_at(planned) + 0.04, "v", color="#2a7ab0", ms=6, mec="black",
                label="planned footholds", zorder=6)
    ax.axvline(args.goal, color="green", ls=":", lw=1.5, label="goal")
    outcome = "reached the goal" if result["success"] else f"failed ({result['failure']})"
    ax.set_title(f"{args.planner} planner + controller on Drake, {args.terrain} terrain seed {args.seed}: {outcome}")
    ax.figure.legends.clear()
    ax.figure.legend(loc="outside lower center", fontsize=8, ncols=8, frameon=False)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    ax.figure.savefig(out, dpi=110)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
