"""Generate the footstep dataset (the paper's Table I) by running a search planner on random terrains.

    python3 examples/generate_dataset.py --out data/footsteps --jobs 2      # Table I: the paper model's data
    python3 examples/generate_dataset.py --planner step --subcells 4 --min-steps 3 --start-x -1 \
        --heights 0.55,1.1 --speeds 0.4,3.2 --out data/subcell --jobs 2    # the sub-cell model's data
    python3 examples/train_expert.py --dry-run   # the expert's rollouts and DAgger rounds (--planner expert)
    python3 examples/generate_dataset.py --out data/footsteps --executor ray --address auto --jobs 64

Each shard is a task of the job runner (drakeslip.jobs): it runs in this process (--jobs 1), in --jobs local
worker processes, or on a Ray cluster with --jobs shards in flight, and returns its arrays; this process writes
each shard atomically as it arrives, so the workers need no filesystem shared with it, and rerunning the same
command resumes: only the missing shards are generated. OUT/config.json records the settings; a folder made with
other settings is refused. --hopper (a hopper file or folder) makes the data for another hopper than the paper's:
its terrains and starts are the paper's made its own as suites drawn for it are, the ranges above in the paper's
units (planners/learned/training/config.py, ``DatasetConfig.hopper``). The shards are the same whatever the
executor and --jobs. The recipes that train the committed models from these datasets are in docs/reproduction.md,
"Regenerating the weights".
"""
from __future__ import annotations

import os
import time

from drakeslip.jobs import cli
from drakeslip import cli_physics
from planners.learned.training.config import DatasetConfig


def parser() -> cli.ArgumentParser:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--out", type=cli.output_folder, default="data/footsteps",
                    help="the dataset folder (shards + config.json)")
    ap.add_argument("--terrains", type=cli.positive_int, default=DatasetConfig.n_terrains,
                    help="terrains, the families alternating")
    ap.add_argument("--apexes", type=cli.positive_int, default=DatasetConfig.apexes_per_terrain,
                    help="initial states per terrain")
    ap.add_argument("--planner", choices=("angle", "step", "expert"), default=DatasetConfig.planner,
                    help="the search whose trees become sequences (angle: the paper's), or the goal-reaching "
                         "expert whose rollouts do (planners/learned/training/expert.py)")
    ap.add_argument("--explore", type=cli.probability, default=None,
                    help=f"--planner expert: chance a rollout hops to a random goal-reaching foothold (default: "
                         f"{DatasetConfig.explore:g})")
    ap.add_argument("--policy", type=cli.input_file, default=None,
                    help="--planner expert: footstep model weights whose one-step mode planner the rollouts "
                         "follow while it stays goal-reaching (DAgger)")
    ap.add_argument("--look-ahead", action="store_true",
                    help="--planner expert: label each state with the foothold that leaves the most room a hop "
                         "later (GoalReachingExpert(look_ahead=True))")
    ap.add_argument("--families", type=cli.names, default=",".join(DatasetConfig.families),
                    help="terrain families, alternating over the terrains, comma-separated")
    ap.add_argument("--subcells", type=cli.positive_int, default=DatasetConfig.subcells,
                    help="output bins per 10 cm cell (1: the paper's); with --planner step, its foothold grid")
    ap.add_argument("--min-steps", type=cli.positive_int, default=DatasetConfig.min_steps,
                    help="shortest sequence kept")
    ap.add_argument("--start-x", type=cli.finite, default=DatasetConfig.start_x,
                    help="first x an instance starts at [m]")
    pair = cli.numbers(2, cli.positive)
    ap.add_argument("--heights", type=pair, default=",".join(map(str, DatasetConfig.height_range)),
                    help="initial apex height above the ground: low,high [m]")
    ap.add_argument("--speeds", type=pair, default=",".join(map(str, DatasetConfig.speed_range)),
                    help="initial apex speed: low,high [m/s]")
    ap.add_argument("--branching", type=cli.positive_int, default=DatasetConfig.branching,
                    help="--planner angle: leg angles tried per node")
    cli_physics.add_hopper_argument(ap)
    ap.add_argument("--friction", type=cli.positive, default=None,
                    help=f"friction coefficient of the searches and rollouts (default: the hopper's, "
                         f"{DatasetConfig.friction} for the paper's)")
    ap.add_argument("--seed", type=cli.non_negative_int, default=DatasetConfig.seed,
                    help="seed of the terrains and initial states")
    ap.add_argument("--shard-size", type=cli.positive_int, default=DatasetConfig.instances_per_shard,
                    help="instances per shard (a task)")
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    cli.add_parallel(ap, jobs=os.cpu_count() or 1)
    return ap


def dataset_hopper(hopper) -> dict | None:
    """``DatasetConfig.hopper`` for --hopper: None for the paper's body (the paper's data), else its fields."""
    from dataclasses import asdict

    from drakeslip.units import PAPER

    if hopper is None or hopper.params.with_friction(PAPER.friction) == PAPER:
        return None
    return asdict(hopper.params)


def checked_config(ap: cli.ArgumentParser, args) -> DatasetConfig:
    """The dataset's settings, or one line and exit status 2 for a bad one, --explore with a planner other than the
    expert (the only one that explores), or a --policy file that is not footstep model weights: all before any
    shard, or config.json, is written."""
    if args.explore is not None and args.planner != "expert":
        ap.error(f"--explore {args.explore:g} is for --planner expert, not {args.planner}")
    try:
        cfg = DatasetConfig(planner=args.planner, min_steps=args.min_steps, start_x=args.start_x,
                            height_range=args.heights, speed_range=args.speeds, n_terrains=args.terrains,
                            apexes_per_terrain=args.apexes, branching=args.branching,
                            friction=args.friction or (args.hopper.params.friction if args.hopper
                                                       else DatasetConfig.friction),
                            hopper=dataset_hopper(args.hopper),
                            seed=args.seed, instances_per_shard=args.shard_size, subcells=args.subcells,
                            explore=DatasetConfig.explore if args.explore is None else args.explore,
                            policy=str(args.policy) if args.policy else "",
                            expert_look_ahead=args.look_ahead, families=tuple(args.families))
    except ValueError as error:
        ap.error(str(error))
    if args.policy:
        from planners.learned.lstm import load_model

        try:
            load_model(args.policy)
        except (OSError, ValueError) as error:  # a damaged or mismatched weights file
            ap.error(f"--policy: {error}")
    return cfg


def main(argv=None):
    ap = parser()
    args = ap.parse_args(argv)
    cfg = checked_config(ap, args)
    try:
        executor = cli.executor(args)
        from tqdm import tqdm

        from planners.learned.training.dataset import count_sequences, generate, pending_shards

        todo = len(pending_shards(cfg, args.out))
        shards = generate(cfg, args.out, executor)  # records the config, or refuses a folder made with another
    except (ValueError, OSError) as error:  # a bad setting, a folder made with others, one that cannot be written
        ap.error(str(error))
    print(f"{cfg.n_instances} instances in {cfg.n_shards} shards; {cfg.n_shards - todo} already done", flush=True)
    t0, sequences = time.perf_counter(), 0
    with tqdm(total=todo, unit="shard", disable=args.quiet) as bar:
        for _, stats in shards:
            if stats is not None:  # None: a shard that was already on disk
                sequences += stats["sequences"]
                bar.set_postfix(sequences=sequences)
                bar.update()
    wall = time.perf_counter() - t0
    print(f"generated {sequences} sequences in {wall:.1f} s ({sequences / max(wall, 1e-9):.1f} sequences/s); "
          f"{args.out} now holds {count_sequences(args.out)} sequences")


if __name__ == "__main__":
    main()
