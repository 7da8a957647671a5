"""Train the foothold ranker (planners/foothold_ranker.py) in DAgger rounds: the committed planners/weights/ranker.pt.

    python3 examples/train_ranker.py --out planners/weights/ranker.pt --jobs 2 --threads 2

Round r draws ``--terrains`` fresh terrains of each family (terrain seeds SEED + 10000 r + 1000 f + i, f the
family's index, so no round reuses a terrain and none meets the evaluation suites' seeds below 100000), runs the
one-step mode planner with the expert-trained footstep model from every case (the suites' ten start states) and
records each state's most probable first footholds with their room a hop later (planners/ranker_train.py);
round 0 follows the mode, later rounds the previous round's ranker. After each round the ranker is trained
afresh on all rounds so far. Shards (DATA_DIR/round{r}-{family}-{seed}.npz) and each round's weights
(DATA_DIR/round{r}.pt) are written atomically; rerunning the same command skips what is there, so a killed run
resumes without losing work (DATA_DIR/config.json records the settings, and other settings are refused).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from drakeslip.files import atomic_write, read_json  # noqa: E402
from drakeslip.pool import results_of  # noqa: E402
from planners.foothold_ranker import save_ranker  # noqa: E402
from planners.lstm_planner import EXPERT_WEIGHTS  # noqa: E402
from planners.ranker_train import RankerTrainConfig, collect, train  # noqa: E402
from planners.suite import TERRAIN_FAMILIES  # noqa: E402


def write_shard(path, family, seed, n_terrains, weights, ranker, record_k, top_k, explore):
    features, rooms = collect(family, seed, n_terrains, weights, ranker, record_k, top_k, explore)
    with atomic_write(path) as f:
        np.savez(f, features=features, rooms=rooms)
    return path, len(rooms)


def load_shards(paths):
    """All states of ``paths``; a shard that does not read raises ValueError naming it."""
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
SETTINGS = ("weights", "families", "terrains", "shard_terrains", "record_k", "top_k", "explore", "seed", "epochs")


def check_config(data: Path, settings: dict) -> None:
    """Record ``settings`` in DATA/config.json, or, resuming, refuse settings other than those recorded (the
    folder's shards and weights were made with those)."""
    settings = json.loads(json.dumps(settings))  # tuples as lists, as read back
    path = data / "config.json"
    if path.exists():
        recorded = read_json(path, "ranker data config")
        changed = sorted(k for k in set(settings) | set(recorded) if settings.get(k) != recorded.get(k))
        if changed:
            diffs = ", ".join(f"{k}: {recorded.get(k)!r}, now {settings.get(k)!r}" for k in changed)
            raise SystemExit(f"{data} was made with other settings ({diffs}); use another --data-dir")
        return
    with atomic_write(path, "w") as f:
        json.dump(settings, f, indent=1)


def positive_int(text):
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text!r}")
    return value


def fraction(text):
    value = float(text)
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"must be a probability in [0, 1], got {text!r}")
    return value


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="planners/weights/ranker.pt", help="the last round's weights go here")
    ap.add_argument("--data-dir", default="data/ranker", help="shards and each round's weights")
    ap.add_argument("--weights", default=str(EXPERT_WEIGHTS), help="the footstep model whose footholds are ranked")
    ap.add_argument("--families", default="ditch,step,mixed")
    ap.add_argument("--rounds", type=positive_int, default=4)
    ap.add_argument("--terrains", type=positive_int, default=300, help="terrains per family and round")
    ap.add_argument("--shard-terrains", type=positive_int, default=25)
    ap.add_argument("--record-k", type=positive_int, default=5, help="candidates recorded per state")
    ap.add_argument("--top-k", type=positive_int, default=5, help="candidates the learner ranks")
    ap.add_argument("--explore", type=fraction, nargs=2, default=(0.5, 0.3), metavar=("ROUND0", "LATER"),
                    help="probability of hopping to the expert's pick in round 0 and in later rounds")
    ap.add_argument("--seed", type=int, default=100000, help="base terrain seed")
    ap.add_argument("--epochs", type=positive_int, default=RankerTrainConfig.epochs)
    ap.add_argument("--threads", type=int, default=0, help="torch threads for training (0: default)")
    ap.add_argument("--jobs", type=positive_int, default=1)
    args = ap.parse_args(argv)
    families = args.families.split(",")
    for family in families:
        if family not in TERRAIN_FAMILIES:
            ap.error(f"unknown terrain family {family!r}; choose from {sorted(TERRAIN_FAMILIES)}")
    if args.terrains > 1000:
        ap.error(f"--terrains must be at most 1000 (the families' seed ranges are 1000 apart), got {args.terrains}")
    data = Path(args.data_dir)
    check_config(data, {k: getattr(args, k) for k in SETTINGS})
    cfg = RankerTrainConfig(epochs=args.epochs, threads=args.threads)
    shards, ranker = [], None
    for r in range(args.rounds):
        todo, explore = [], args.explore[0] if r == 0 else args.explore[1]
        for family in families:
            for start in range(0, args.terrains, args.shard_terrains):
                seed = args.seed + 10000 * r + 1000 * sorted(TERRAIN_FAMILIES).index(family) + start
                path = data / f"round{r}-{family}-{seed}.npz"
                shards.append(path)
                if not path.exists():
                    todo.append((path, family, seed, min(args.shard_terrains, args.terrains - start), args.weights,
                                 ranker, args.record_k, args.top_k, explore))
        t0, states = time.time(), 0
        with tqdm(total=len(todo), unit="shard", desc=f"round {r}") as bar:
            for _, (_, n) in results_of(write_shard, [(job[0], job) for job in todo], args.jobs):
                states += n
                bar.update()
        if todo:
            print(f"round {r}: {states} states in {len(todo)} shards, {time.time() - t0:.1f} s "
                  f"({states / max(time.time() - t0, 1e-9):.1f} states/s)")
        weights = data / f"round{r}.pt"
        if not weights.exists():
            features, rooms = load_shards(shards)
            net, mean, std, summary = train(features, rooms, cfg, log=lambda row: print(json.dumps(row)))
            save_ranker(weights, net, mean, std, {"round": r, "summary": summary, "footstep_model": args.weights})
            print(json.dumps({"round": r, **summary}))
        ranker = str(weights)
    with atomic_write(args.out) as f:
        f.write(Path(ranker).read_bytes())
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
