"""Train the CNN+LSTM footstep model on a dataset from examples/generate_dataset.py.

    python3 examples/train_lstm.py --data data/footsteps --epochs 30 --out out/lstm.pt [--device cuda]

Logs train/validation loss and top-1 / within-1-cell accuracy each epoch, checkpoints every epoch (rerun
the same command to resume) and writes the best weights to --out (default: the committed
planners/weights/lstm_paper.pt, the paper's model that planners.make("lstm@paper") loads); the SHA256SUMS manifest of
--out's folder, if it has one, gets the file's new digest. Training runs on --device (default: CUDA when torch
sees a GPU, else the CPU).

Exit status: 0 when training finished, 2 for a usage or input error (a missing or malformed dataset, damaged
--init weights, an unavailable device).
"""
from __future__ import annotations

import json
import os
import sys
import time

from drakeslip.jobs import cli
from drakeslip.devices import DEVICE_HELP, torch_device
from planners.learned.config import ModelConfig
from planners.learned.training.config import TrainConfig

SELECTORS = ("", "ditch", "no-ditch")


def dataset_spec(text: str) -> str:
    """An argument type: dataset folders, comma-separated, each FOLDER, FOLDER:ditch or FOLDER:no-ditch, each
    holding dataset shards (*.npz)."""
    import argparse

    parts = text.split(",")
    for part in parts:
        folder, _, select = part.partition(":")
        if select not in SELECTORS:
            raise argparse.ArgumentTypeError(f"selector {select!r} in {part!r}: use FOLDER, FOLDER:ditch or "
                                             "FOLDER:no-ditch")
        if not os.path.isdir(folder):
            raise argparse.ArgumentTypeError(f"no dataset folder {folder!r}")
        if not any(f.endswith(".npz") for f in os.listdir(folder)):
            raise argparse.ArgumentTypeError(f"no dataset shards (*.npz) in {folder!r}")
    return text


def checkpoint_file(text: str):
    """An argument type: a .pt file to write, or '' for none."""
    return "" if text == "" else cli.output_file(".pt")(text)


def arguments() -> cli.ArgumentParser:
    d = TrainConfig()
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--data", type=dataset_spec, default=d.data,
                    help="dataset folder, or several comma-separated; FOLDER:ditch or FOLDER:no-ditch keeps only the "
                         "sequences whose window holds a ditch, or none")
    ap.add_argument("--init", type=cli.input_file, default=None,
                    help="weights to fine-tune instead of training a fresh model (none: a fresh model)")
    ap.add_argument("--out", type=cli.output_file(".pt"), default=d.out, help="best weights (written atomically)")
    ap.add_argument("--checkpoint", type=checkpoint_file, default=d.checkpoint,
                    help="resumable training state, a .pt file ('' to disable)")
    ap.add_argument("--epochs", type=cli.positive_int, default=d.epochs, help="training epochs (in all, when resuming)")
    ap.add_argument("--batch-size", type=cli.positive_int, default=d.batch_size, help="sequences per batch")
    ap.add_argument("--lr", type=cli.positive, default=d.lr, help="peak learning rate (cosine schedule)")
    ap.add_argument("--own-inputs", type=cli.probability, default=d.own_inputs,
                    help="fraction of sequences trained on the model's own distributions as inputs")
    ap.add_argument("--viable-weight", type=cli.probability, default=d.viable_weight,
                    help="soft labels: share of each target spread over the step's viable set (0: the paper's)")
    ap.add_argument("--max-sequences", type=cli.non_negative_int, default=d.max_sequences,
                    help="train on the first N sequences only (0: all)")
    ap.add_argument("--seed", type=cli.non_negative_int, default=d.seed,
                    help="seeds the split, the batches and the network")
    ap.add_argument("--device", default="auto", help=DEVICE_HELP)
    ap.add_argument("--threads", type=cli.non_negative_int, default=0, help="torch CPU threads (0: torch's default)")
    ap.add_argument("--hidden", type=cli.positive_int, default=ModelConfig.hidden,
                    help="LSTM units per layer (110: the paper)")
    ap.add_argument("--channels", type=cli.positive_int, default=ModelConfig.channels, help="CNN feature maps")
    ap.add_argument("--quiet", action="store_true", help="no per-epoch log lines")
    return ap


def main(argv=None) -> int:
    ap = arguments()
    args = ap.parse_args(argv)

    import torch

    from planners.learned.model import load_checkpoint
    from planners.learned.training.train_lstm import train

    try:
        device = torch_device(args.device)
    except ValueError as error:
        ap.error(f"--device: {error}")
    if args.init:
        try:
            load_checkpoint(args.init)
        except (OSError, ValueError) as error:
            ap.error(f"--init: {error}")
    if args.threads:
        torch.set_num_threads(args.threads)
    cfg = TrainConfig(data=args.data, out=str(args.out), checkpoint=str(args.checkpoint), epochs=args.epochs,
                      batch_size=args.batch_size, lr=args.lr, own_inputs=args.own_inputs, seed=args.seed,
                      device=device, max_sequences=args.max_sequences, viable_weight=args.viable_weight,
                      init=str(args.init) if args.init else "")
    t0 = time.perf_counter()
    log = (lambda *_, **__: None) if args.quiet else print
    try:
        summary = train(cfg, log=log, width=(args.hidden, args.channels))
    except ValueError as error:  # the dataset's content: mixed bins, no viable sets for --viable-weight, a width
        ap.error(str(error))     # the --init model does not have (raised before the first epoch)
    last = summary["history"][-1] if summary["history"] else {}
    print(json.dumps({"train_seconds": round(time.perf_counter() - t0, 1), "n_train": summary["n_train"],
                      "n_val": summary["n_val"], "best_val_loss": round(summary["best_val_loss"], 4),
                      "last_epoch": last}, indent=1))
    return cli.OK


if __name__ == "__main__":
    sys.exit(main())
