"""Generate the footstep dataset (the paper's Table I) by running a search planner on random terrains.

    python3 examples/generate_dataset.py --out data/footsteps --jobs 2      # Table I: the committed model's data
    python3 examples/generate_dataset.py --planner step --min-steps 3 --start-x -1 --heights 0.55,1.1 \
        --speeds 0.4,3.2 --out data/steps --jobs 2                         # the Step-space ablation (README)
    python3 examples/generate_dataset.py --planner expert --policy out/lstm_expert_round0.pt --explore 0.1 \
        --subcells 4 --min-steps 1 --start-x -1 --heights 0.55,1.1 --speeds 0.4,3.2 --friction 0.8 \
        --terrains 500 --seed 1 --out data/dagger1 --jobs 2     # a DAgger round (docs/results.md, "DAgger")
    python3 examples/generate_dataset.py --planner expert --look-ahead --families ditch \
        --policy planners/weights/lstm_expert.pt --explore 0.1 --subcells 4 --min-steps 1 --start-x -1 \
        --heights 0.55,1.1 --speeds 0.4,3.2 --friction 0.8 --terrains 250 --seed 3 --out data/lookahead1 --jobs 2
                                              # ditch states labelled by the look-ahead expert (docs/results.md)
    python3 examples/generate_dataset.py --out data/footsteps --executor ray [--ray-address auto]

Shards are written atomically; rerunning the same command resumes and only generates the missing shards.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

from tqdm import tqdm

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from drakeslip.pool import results_of  # noqa: E402
from planners.dataset import (DatasetConfig, count_sequences, pending_shards, write_manifest,  # noqa: E402
                              write_shard)


def run_local(cfg, shards, out, jobs):
    for _, result in results_of(write_shard, [(k, (cfg, k, out)) for k in shards], jobs):
        yield result


def run_ray(cfg, shards, out, address):
    import ray

    ray.init(address=address, ignore_reinit_error=True, log_to_driver=False)
    remote = ray.remote(write_shard)
    pending = [remote.remote(cfg, k, out) for k in shards]
    while pending:
        done, pending = ray.wait(pending, num_returns=1)
        yield ray.get(done[0])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="data/footsteps", help="dataset folder (shards + config.json)")
    ap.add_argument("--terrains", type=int, default=DatasetConfig.n_terrains)
    ap.add_argument("--apexes", type=int, default=DatasetConfig.apexes_per_terrain, help="initial states per terrain")
    ap.add_argument("--planner", choices=("angle", "step", "expert"), default=DatasetConfig.planner,
                    help="the search whose trees become sequences (angle: the paper's), or the goal-reaching "
                         "expert whose rollouts do (planners/expert.py)")
    ap.add_argument("--explore", type=float, default=DatasetConfig.explore,
                    help="--planner expert: chance a rollout hops to a random goal-reaching foothold")
    ap.add_argument("--policy", default="",
                    help="--planner expert: footstep model weights whose one-step mode planner the rollouts "
                         "follow while it stays goal-reaching (DAgger)")
    ap.add_argument("--look-ahead", action="store_true",
                    help="--planner expert: label each state with the foothold that leaves the most room a hop "
                         "later (GoalReachingExpert(look_ahead=True))")
    ap.add_argument("--families", default=",".join(DatasetConfig.families),
                    help="terrain families, alternating over the terrains, comma-separated")
    ap.add_argument("--subcells", type=int, default=DatasetConfig.subcells,
                    help="output bins per 10 cm cell (1: the paper's); with --planner step, its foothold grid")
    ap.add_argument("--min-steps", type=int, default=DatasetConfig.min_steps, help="shortest sequence kept")
    ap.add_argument("--start-x", type=float, default=DatasetConfig.start_x, help="first x an instance starts at")
    ap.add_argument("--heights", default=",".join(map(str, DatasetConfig.height_range)),
                    help="initial apex height above the ground: low,high [m]")
    ap.add_argument("--speeds", default=",".join(map(str, DatasetConfig.speed_range)),
                    help="initial apex speed: low,high [m/s]")
    ap.add_argument("--branching", type=int, default=DatasetConfig.branching)
    ap.add_argument("--friction", type=float, default=DatasetConfig.friction)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--shard-size", type=int, default=DatasetConfig.instances_per_shard, help="instances per shard")
    ap.add_argument("--jobs", type=int, default=os.cpu_count(), help="local worker processes")
    ap.add_argument("--executor", choices=("local", "ray"), default="local")
    ap.add_argument("--ray-address", default=None, help="Ray cluster address (default: start a local instance)")
    args = ap.parse_args(argv)
    if args.jobs < 1:
        ap.error(f"--jobs must be at least 1, got {args.jobs}")
    pair = lambda text, name: tuple(float(v) for v in text.split(",")) if len(text.split(",")) == 2 else \
        ap.error(f"--{name} must be low,high, got {text!r}")
    try:
        cfg = DatasetConfig(planner=args.planner, min_steps=args.min_steps, start_x=args.start_x,
                            height_range=pair(args.heights, "heights"), speed_range=pair(args.speeds, "speeds"),
                            n_terrains=args.terrains, apexes_per_terrain=args.apexes, branching=args.branching,
                            friction=args.friction, seed=args.seed, instances_per_shard=args.shard_size,
                            subcells=args.subcells, explore=args.explore, policy=args.policy,
                            expert_look_ahead=args.look_ahead, families=tuple(args.families.split(",")))
    except ValueError as error:
        ap.error(str(error))
    write_manifest(cfg, args.out)
    shards = pending_shards(cfg, args.out)
    print(f"{cfg.n_instances} instances in {cfg.n_shards} shards; {cfg.n_shards - len(shards)} already done")
    t0 = time.perf_counter()
    results = run_ray(cfg, shards, args.out, args.ray_address) if args.executor == "ray" else \
        run_local(cfg, shards, args.out, args.jobs)
    sequences = 0
    with tqdm(total=len(shards), unit="shard") as bar:
        for r in results:
            sequences += r["sequences"]
            bar.set_postfix(sequences=sequences)
            bar.update()
    wall = time.perf_counter() - t0
    print(f"generated {sequences} sequences in {wall:.1f} s ({sequences / max(wall, 1e-9):.1f} sequences/s); "
          f"{args.out} now holds {count_sequences(args.out)} sequences")


if __name__ == "__main__":
    main()
