"""Train the foothold ranker (planners/learned/ranker.py) in DAgger rounds: the committed planners/weights/ranker.pt.

    python3 examples/train_ranker.py --out planners/weights/ranker.pt --jobs 2 --threads 2 [--device cuda]
    python3 examples/train_ranker.py --out planners/weights/ranker.pt --executor ray --address auto --jobs 64

Round r draws ``--terrains`` fresh terrains of each family (terrain seeds SEED + 10000 r + 1000 f + i, f the
family's index, so no round reuses a terrain and none meets the evaluation suites' seeds below 100000), runs the
one-step mode planner with the expert-trained footstep model from every case (the suites' ten start states) and
records each state's most probable first footholds with their room a hop later
(planners/learned/training/train_ranker.py); round 0 follows the mode, later rounds the previous round's ranker.
After each round the ranker is trained afresh on all rounds so far, in this process, on --device (default: CUDA
when torch sees a GPU, else the CPU). The last round's weights are copied to --out, and the SHA256SUMS manifest of
--out's folder, if it has one, gets the file's new digest.

A shard of --shard-terrains terrains is a task of the job runner (drakeslip.jobs): it runs in this process
(--jobs 1), in --jobs local worker processes, or on a Ray cluster with --jobs shards in flight, gets the weights
it needs from this process and returns its states, which this process writes. Shards
(DATA_DIR/round{r}-{family}-{seed}.npz) and each round's weights (DATA_DIR/round{r}.pt) are written atomically;
rerunning the same command skips what is there, so a killed run resumes without losing work (DATA_DIR/config.json
records the settings, and other settings are refused). The shards are the same whatever the executor and --jobs.
--hopper (a hopper file or folder) trains the ranker for another hopper than the paper's: the cases are those of
suites drawn for it (planners/formats/suite_draw.py); give it --model, the footstep model trained for it.
"""
from __future__ import annotations

import json
import os
import sys
import time
from dataclasses import asdict
from pathlib import Path

from drakeslip.jobs import cli
from drakeslip import cli_physics
from drakeslip.devices import DEVICE_HELP, torch_device
from drakeslip.jobs.files import atomic_write, read_json, record_digest
from drakeslip.terrain import TERRAIN_FAMILIES, check_families
from drakeslip.units import PAPER
from planners.checkpoints import EXPERT_WEIGHTS
from planners.learned.training.config import RankerTrainConfig


def load_shards(paths):
    """All states of ``paths``; a shard that does not read raises ValueError naming it."""
    import numpy as np

    features, rooms = [], []
    for p in paths:
        try:
            with np.load(p) as d:
                features.append(d["features"])
                rooms.append(d["rooms"])
        except Exception as err:
            raise ValueError(f"ranker data shard {p} does not read ({err}); delete it and rerun to redo it") from err
    return np.concatenate(features), np.concatenate(rooms)


# what the shards and round weights in a data folder depend on (--rounds may grow, --jobs and --threads vary)
SETTINGS = ("model", "families", "terrains", "shard_terrains", "record_k", "top_k", "explore", "seed", "epochs")


def check_config(data: Path, settings: dict) -> None:
    """Record ``settings`` in DATA/config.json, or, resuming, refuse settings other than those recorded (the
    folder's shards and weights were made with those)."""
    settings = json.loads(json.dumps(settings))  # tuples as lists, as read back
    path = data / "config.json"
    if path.exists():
        recorded = read_json(path, "ranker data config")
        if not isinstance(recorded, dict):
            raise ValueError(f"ranker data config {path} is not a JSON object")
        if isinstance(recorded.get("model"), str):  # the same file spelled another way (dir/../x) is no change
            recorded["model"] = os.path.normpath(recorded["model"])
        settings["model"] = os.path.normpath(settings["model"])
        changed = sorted(k for k in set(settings) | set(recorded) if settings.get(k) != recorded.get(k))
        if changed:
            diffs = ", ".join(f"{k}: {recorded.get(k)!r}, now {settings.get(k)!r}" for k in changed)
            raise SystemExit(f"{data} was made with other settings ({diffs}); use another --data-dir")
        return
    with atomic_write(path, "w") as f:
        json.dump(settings, f, indent=1)


def parser() -> cli.ArgumentParser:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--out", type=cli.output_file(".pt"), default="planners/weights/ranker.pt",
                    help="the last round's weights go here")
    ap.add_argument("--data-dir", type=cli.output_folder, default="data/ranker",
                    help="shards and each round's weights")
    ap.add_argument("--model", type=cli.input_file, default=str(EXPERT_WEIGHTS),
                    help="the footstep model whose footholds are ranked")
    cli_physics.add_hopper_argument(ap)
    ap.add_argument("--families", type=cli.names, default="ditch,step,mixed",
                    help="terrain families, comma-separated")
    ap.add_argument("--rounds", type=cli.positive_int, default=4, help="DAgger rounds")
    ap.add_argument("--terrains", type=cli.integer(1, 1000), default=300,
                    help="terrains per family and round (at most 1000: the families' seed ranges are 1000 apart)")
    ap.add_argument("--shard-terrains", type=cli.positive_int, default=25, help="terrains per shard (a task)")
    ap.add_argument("--record-k", type=cli.positive_int, default=5, help="candidates recorded per state")
    ap.add_argument("--top-k", type=cli.positive_int, default=5, help="candidates the learner ranks")
    ap.add_argument("--explore", type=cli.probability, nargs=2, default=(0.5, 0.3), metavar=("ROUND0", "LATER"),
                    help="probability of hopping to the expert's pick in round 0 and in later rounds")
    ap.add_argument("--seed", type=cli.non_negative_int, default=100000, help="base terrain seed")
    ap.add_argument("--epochs", type=cli.positive_int, default=RankerTrainConfig.epochs,
                    help="training epochs per round")
    ap.add_argument("--threads", type=cli.non_negative_int, default=0,
                    help="torch threads for training (0: torch's default)")
    ap.add_argument("--device", default="auto", help=DEVICE_HELP)
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    cli.add_parallel(ap)
    return ap


def checked_device(ap: cli.ArgumentParser, args):
    """The torch device to train on, or one line and exit status 2 for a bad --families or --device."""
    try:
        check_families(args.families)
    except ValueError as error:
        ap.error(f"--families: {error}")
    try:
        return torch_device(args.device)
    except ValueError as error:
        ap.error(f"--device: {error}")


def checked_settings(ap: cli.ArgumentParser, args, data: Path):
    """(the settings DATA/config.json records, the hopper's parameters or None for the paper's), or one line and
    exit status 2 when the folder was made with other settings or its config does not read."""
    # as the folder records them: the paths and the family list as typed
    settings = {k: getattr(args, k) for k in SETTINGS} | {"model": str(args.model),
                                                          "families": ",".join(args.families)}
    hopper = None   # the paper's: its folders' settings stay as they were
    if args.hopper is not None and args.hopper.params.with_friction(PAPER.friction) != PAPER:
        hopper = asdict(args.hopper.params)
        settings["hopper"] = hopper
    try:
        check_config(data, settings)
    except SystemExit as refused:  # a usage error: one line, exit status 2 (the exception keeps its message)
        print(f"{ap.prog}: error: {refused}", file=sys.stderr)
        refused.code = cli.USAGE
        raise
    except (ValueError, OSError) as error:  # a config.json that does not parse, a folder that cannot be written
        ap.error(str(error))
    return settings, hopper


def round_tasks(r: int, args, model: bytes, learner: bytes | None, hopper: dict | None) -> list:
    """Round ``r``'s tasks, (shard file name, collect_shard's arguments), family by family."""
    tasks, explore = [], args.explore[0] if r == 0 else args.explore[1]
    for family in args.families:
        for start in range(0, args.terrains, args.shard_terrains):
            seed = args.seed + 10000 * r + 1000 * sorted(TERRAIN_FAMILIES).index(family) + start
            tasks.append((f"round{r}-{family}-{seed}.npz",
                          (family, seed, min(args.shard_terrains, args.terrains - start), model, learner,
                           args.record_k, args.top_k, explore, hopper)))
    return tasks


def collect(r: int, tasks: list, store, executor, quiet: bool) -> None:
    """Run the tasks whose shards are not in ``store`` yet, and say how many states they recorded."""
    from tqdm import tqdm

    from drakeslip.jobs.runner import run
    from planners.learned.training.train_ranker import collect_shard

    todo = sum(store.get(name) is None for name, _ in tasks)
    t0, states = time.time(), 0
    with tqdm(total=todo, unit="shard", desc=f"round {r}", disable=quiet) as bar:
        for _, shard in run(collect_shard, tasks, store, executor):
            if not isinstance(shard, str):  # a str: the path of a shard already on disk
                states += len(shard[1])
                bar.update()
    if todo:
        print(f"round {r}: {states} states in {todo} shards, {time.time() - t0:.1f} s "
              f"({states / max(time.time() - t0, 1e-9):.1f} states/s)")


def trained(r: int, shards: list, data: Path, cfg, footstep_model: str) -> Path:
    """DATA/round{r}.pt: the ranker trained on ``shards`` (unless it is there already)."""
    from planners.learned.ranker import save_ranker
    from planners.learned.training.train_ranker import train

    ranker = data / f"round{r}.pt"
    if not ranker.exists():
        features, rooms = load_shards(shards)
        net, mean, std, summary = train(features, rooms, cfg, log=lambda row: print(json.dumps(row)))
        save_ranker(ranker, net, mean, std, {"round": r, "summary": summary, "footstep_model": footstep_model})
        print(json.dumps({"round": r, **summary}))
    return ranker


def main(argv=None):
    ap = parser()
    args = ap.parse_args(argv)
    device = checked_device(ap, args)
    executor = cli.executor(args)
    data = Path(args.data_dir)
    settings, hopper = checked_settings(ap, args, data)

    from planners.learned.training.train_ranker import shard_store

    cfg = RankerTrainConfig(epochs=args.epochs, threads=args.threads, device=device)
    store, model = shard_store(data), Path(args.model).read_bytes()
    shards, ranker = [], None
    for r in range(args.rounds):
        learner = None if ranker is None else ranker.read_bytes()  # the tasks get the files' contents
        tasks = round_tasks(r, args, model, learner, hopper)
        shards += [data / name for name, _ in tasks]
        collect(r, tasks, store, executor, args.quiet)
        ranker = trained(r, shards, data, cfg, settings["model"])
    with atomic_write(args.out) as f:
        f.write(ranker.read_bytes())
    record_digest(args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
