"""Foothold error of the step-length controller on flat and stepped terrain.

    python examples/controller_accuracy.py --samples 20000 --drake 40 --seed 0

Targets are footholds the hopper really reaches: random apex states (0.5-3 m/s, 0.7-1.2 m above the ground)
and leg angles are simulated with the fast step map and the successful touchdowns kept. The controller is
then asked for each of those footholds and its leg angle simulated again: the error is |landed - target|.
A random subset is re-run on the Drake simulator to confirm.
"""
from __future__ import annotations

import argparse
import shlex
import sys

import numpy as np

from drakeslip import SlipParams, Terrain, step, step_batch, step_world
from drakeslip.controller import DEFAULT_WEIGHTS, StepLengthController


def targets(terrain: Terrain, params: SlipParams, n: int, rng):
    x = rng.uniform(-1.0, 15.0, n)
    apex = np.stack([x, terrain.height_at(x) + rng.uniform(0.7, 1.2, n), rng.uniform(0.5, 3.0, n)], axis=1)
    res = step_batch(apex, rng.uniform(-0.6, 0.6, n), terrain, params, parallel=True)
    return apex[res.ok], res.touchdown_x[res.ok]


def stats(err) -> str:
    """Error quantiles over the targets the foot landed near; a touchdown that never happened (the foot met a
    step face or tripped) or landed 5 cm or more away is counted as a miss instead."""
    err = np.asarray(err)
    hit = err < 0.05
    e = err[hit]
    return (f"median {1e3 * np.median(e):9.3g} mm   p90 {1e3 * np.quantile(e, 0.9):9.3g} mm   "
            f"max {1e3 * e.max():9.3g} mm   misses {np.count_nonzero(~hit)}/{err.size}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--weights", default=str(DEFAULT_WEIGHTS))
    ap.add_argument("--samples", type=int, default=20000,
                    help="random hops per terrain kind (before keeping the successful ones)")
    ap.add_argument("--drake", type=int, default=40, help="targets per terrain kind re-run on the Drake simulator")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    print("reproduce with: python " + " ".join(shlex.quote(a) for a in [sys.argv[0]] + (argv or sys.argv[1:])))
    controller = StepLengthController.load(args.weights)
    params = SlipParams()
    rng = np.random.default_rng(args.seed)
    kinds = [("flat", [Terrain.flat(length=25.0)]), ("stepped (step_world 0-9)", [step_world(s) for s in range(10)])]
    for name, terrains in kinds:
        cases = [(t, *targets(t, params, args.samples // len(terrains), rng)) for t in terrains]
        for backend in ("fast", "drake"):
            for refine in (False, True):
                errors = []
                for t, apex, target in cases:
                    if backend == "drake":  # a few per terrain, spread over the terrains
                        k = -(-args.drake // len(terrains))
                        apex, target = apex[:k], target[:k]
                    theta = controller.leg_angles(apex, target, t, refine=refine)
                    if backend == "fast":
                        landed = step_batch(apex, theta, t, params, parallel=True).touchdown_x
                    else:
                        landed = np.array([step(a, th, t, params, backend="drake").touchdown_x
                                           for a, th in zip(apex, theta)])
                    errors.append(np.abs(np.nan_to_num(landed, nan=np.inf) - target))
                label = f"{name:<25} {backend:<5} {'refined' if refine else 'MLP only':<8}"
                print(f"{label} {stats(np.concatenate(errors))}")


if __name__ == "__main__":
    main()
