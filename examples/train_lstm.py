"""Train the CNN+LSTM footstep model on a dataset from examples/generate_dataset.py.

    python3 examples/train_lstm.py --data data/footsteps --epochs 30 [--device cuda]

Logs train/validation loss and top-1 / within-1-cell accuracy each epoch, checkpoints every epoch (rerun
the same command to resume) and writes the best weights to --out (default: the committed
planners/weights/lstm.pt that planners.make("lstm") loads).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

import torch

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from planners.lstm_model import ModelConfig  # noqa: E402
from planners.lstm_train import TrainConfig, train  # noqa: E402


def main(argv=None):
    d = TrainConfig()
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", default=d.data, help="dataset folder, or several comma-separated; FOLDER:ditch or "
                    "FOLDER:no-ditch keeps only the sequences whose window holds a ditch, or none")
    ap.add_argument("--init", default=d.init, help="weights to fine-tune instead of training a fresh model")
    ap.add_argument("--out", default=d.out)
    ap.add_argument("--checkpoint", default=d.checkpoint, help="resumable training state ('' to disable)")
    ap.add_argument("--epochs", type=int, default=d.epochs)
    ap.add_argument("--batch-size", type=int, default=d.batch_size)
    ap.add_argument("--lr", type=float, default=d.lr)
    ap.add_argument("--own-inputs", type=float, default=d.own_inputs,
                    help="fraction of sequences trained on the model's own distributions as inputs")
    ap.add_argument("--viable-weight", type=float, default=d.viable_weight,
                    help="soft labels: share of each target spread over the step's viable set (0: the paper's)")
    ap.add_argument("--max-sequences", type=int, default=0)
    ap.add_argument("--seed", type=int, default=d.seed)
    ap.add_argument("--device", default="cuda" if torch.cuda.is_available() else "cpu")
    ap.add_argument("--threads", type=int, default=0, help="torch CPU threads (0: torch's default)")
    ap.add_argument("--hidden", type=int, default=ModelConfig.hidden, help="LSTM units per layer (110: the paper)")
    ap.add_argument("--channels", type=int, default=ModelConfig.channels, help="CNN feature maps")
    args = ap.parse_args(argv)
    if args.hidden < 1 or args.channels < 1:
        ap.error(f"--hidden and --channels must be positive, got {args.hidden} and {args.channels}")
    if args.init and not os.path.isfile(args.init):
        ap.error(f"--init: no weights file {args.init!r}")
    if args.threads:
        torch.set_num_threads(args.threads)
    cfg = TrainConfig(data=args.data, out=args.out, checkpoint=args.checkpoint, epochs=args.epochs,
                      batch_size=args.batch_size, lr=args.lr, own_inputs=args.own_inputs, seed=args.seed,
                      device=args.device, max_sequences=args.max_sequences, viable_weight=args.viable_weight,
                      init=args.init)
    t0 = time.perf_counter()
    summary = train(cfg, width=(args.hidden, args.channels))
    last = summary["history"][-1] if summary["history"] else {}
    print(json.dumps({"train_seconds": round(time.perf_counter() - t0, 1), "n_train": summary["n_train"],
                      "n_val": summary["n_val"], "best_val_loss": round(summary["best_val_loss"], 4),
                      "last_epoch": last}, indent=1))


if __name__ == "__main__":
    main()
