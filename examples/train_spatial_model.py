"""Make the spatial footstep model's dataset and train the model the height-map planners are guided by.

    python3 examples/train_spatial_model.py --jobs 2        # the committed planners/weights/spatial_footstep.pt

The dataset (planners/learned/training/spatial_dataset.py): --cases receding-horizon runs of Step-space on random
height maps of every family (--seed), each planning call's plan a set of samples; its shards are written to --data as
they finish, so rerunning the same command resumes, and a folder made with other settings is refused. Then the model
trains from scratch (planners/learned/training/train_spatial.py) on --device (auto: CUDA when torch sees a GPU) and
its weights go to --out, their SHA-256 into the folder's SHA256SUMS when it has one (the committed weights are checked
against it when loaded). The same command on the same code writes the same dataset; training on the CPU is
deterministic for a given torch build.

Exit status: 0 when the weights were written, 2 for a usage or input error (a folder made with other settings, an
unavailable device).
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from drakeslip.jobs import cli
from drakeslip.devices import DEVICE_HELP, torch_device
from drakeslip.spatial.families import HEIGHT_MAP_FAMILIES, check_height_map_families

DATA, OUT = "data/spatial", "planners/weights/spatial_footstep.pt"


def arguments() -> cli.ArgumentParser:
    from planners.learned.training.config import SpatialDatasetConfig, SpatialTrainConfig

    d, t = SpatialDatasetConfig(), SpatialTrainConfig()
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--data", type=cli.output_folder, default=DATA, help="the dataset folder (shards + config.json)")
    ap.add_argument("--out", type=cli.output_file(".pt"), default=OUT, help="the weights (written atomically)")
    ap.add_argument("--cases", type=cli.positive_int, default=d.cases, help="receding-horizon runs in the dataset")
    ap.add_argument("--families", type=cli.names, default=",".join(d.families),
                    help=f"height-map families, alternating over the runs, from {','.join(HEIGHT_MAP_FAMILIES)}")
    ap.add_argument("--seed", type=cli.non_negative_int, default=d.seed, help="seed of the maps, starts and goals")
    ap.add_argument("--epochs", type=cli.positive_int, default=t.epochs, help="training epochs")
    ap.add_argument("--device", default="auto", help=DEVICE_HELP)
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    cli.add_parallel(ap)
    return ap


def main(argv=None) -> int:
    ap = arguments()
    args = ap.parse_args(argv)
    try:
        check_height_map_families(args.families)
    except ValueError as error:
        ap.error(f"--families: {error}")
    try:
        device = torch_device(args.device)
    except ValueError as error:
        ap.error(f"--device: {error}")
    import drakeslip as ds
    from planners.learned.training.config import SpatialDatasetConfig, SpatialTrainConfig
    from planners.learned.training.spatial_dataset import make_shard, write_shard
    from planners.learned.training.train_spatial import train_spatial

    cfg = SpatialDatasetConfig(tuple(args.families), args.cases, seed=args.seed)
    record = Path(args.data) / "config.json"
    if record.exists() and record.read_text() != cfg.to_json():
        ap.error(f"--data {args.data} holds a dataset made with other settings ({record}); use another folder")
    executor = cli.executor(args)
    cli.announce(argv)
    record.parent.mkdir(parents=True, exist_ok=True)
    record.write_text(cfg.to_json())
    make_dataset(cfg, Path(args.data), executor, ds.SlipParams(), args.quiet, make_shard, write_shard)
    report = train_spatial(SpatialTrainConfig(str(args.data), str(args.out), args.epochs, device=device))
    print(f"wrote {args.out}: held-out loss {report['loss']:.4f}, the label's best cell among the model's top 1 / 4 / "
          f"8 cells in {report['top1']:.1%} / {report['top4']:.1%} / {report['top8']:.1%} of the samples")
    return cli.OK


# many parameters: the dataset's settings, where it goes, how it runs, and the two shard functions it is made of
def make_dataset(cfg, folder: Path, executor, params, quiet: bool, make_shard, write_shard) -> None:
    """Make the missing shards of ``cfg`` in ``folder``, on ``executor``, with a progress bar."""
    from tqdm import tqdm

    from drakeslip.jobs.runner import FileStore, run

    store = FileStore(folder, lambda k: f"shard-{k:04d}.npz", write_shard, read=lambda path: str(path))
    tasks = [(k, (cfg, k, params)) for k in range(cfg.n_shards)]
    with tqdm(total=len(tasks), unit="shard", disable=quiet) as bar:
        for _ in run(make_shard, tasks, store, executor):
            bar.update()
    print(json.dumps({"shards": cfg.n_shards, "cases": cfg.cases}))


if __name__ == "__main__":
    sys.exit(main())
