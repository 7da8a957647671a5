"""Time the fast and the Drake step maps side by side, in one process, on the same random hops.

    python3 examples/bench_backends.py --cases 30 --seed 0
"""
import argparse

import numpy as np

import drakeslip as ds
from verification.backend_agreement import best_time, draw_cases

N_ANGLES = 30  # the batch: this many leg angles from each apex, as a planner expands a node


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=30, help="random hops timed on both backends (default 30)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the random hops (default 0)")
    parser.add_argument("--families", default="step,ditch", help="comma-separated terrain families")
    parser.add_argument("--repeats", type=int, default=20, help="fast-backend repetitions per case (best kept)")
    args = parser.parse_args()
    params = ds.SlipParams()
    cases = draw_cases(args.cases, args.seed, tuple(args.families.split(",")), params)
    terrains = [case.terrain() for case in cases]
    angles = np.linspace(-params.max_leg_angle, params.max_leg_angle, N_ANGLES)
    ds.step_batch(cases[0].apex, angles, terrains[0], params)  # load the compiled kernel before timing

    single, batch, drake = [], [], []
    for case, terrain in zip(cases, terrains):
        single.append(best_time(lambda: ds.step(case.apex, case.leg_angle, terrain, params), args.repeats))
        batch.append(best_time(lambda: ds.step_batch(case.apex, angles, terrain, params), args.repeats) / N_ANGLES)
        drake.append(best_time(lambda: ds.step(case.apex, case.leg_angle, terrain, params, backend="drake"), 1))
    single_us, batch_us, drake_us = (np.median(t) * 1e6 for t in (single, batch, drake))
    print(f"{args.cases} random hops ({args.families}), median time per step:")
    print(f"  fast, one step per call      {single_us:10.1f} us   Drake / fast = {drake_us / single_us:8.0f}x")
    print(f"  fast, batch of {N_ANGLES} angles     {batch_us:10.1f} us   Drake / fast = {drake_us / batch_us:8.0f}x")
    print(f"  drake                        {drake_us:10.1f} us")


if __name__ == "__main__":
    main()
