"""Retrain the step-length controller and write its weights (default: the committed drakeslip/weights/controller.pt).

    python examples/train_controller.py --seed 0 --epochs 300
"""
from __future__ import annotations

import argparse
import shlex
import sys
import time
from dataclasses import replace

import numpy as np

from drakeslip import SlipParams, Terrain
from drakeslip.controller import DEFAULT_WEIGHTS, ControllerConfig
from drakeslip.controller_training import DataConfig, TrainConfig, make_dataset, train


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=str(DEFAULT_WEIGHTS), help="weights file to write (atomically)")
    ap.add_argument("--seed", type=int, default=0, help="seeds the grid jitter, the split and the network")
    ap.add_argument("--epochs", type=int, default=TrainConfig.epochs)
    ap.add_argument("--hidden", type=int, default=ControllerConfig.hidden)
    ap.add_argument("--layers", type=int, default=ControllerConfig.layers)
    ap.add_argument("--angles", type=int, default=DataConfig.angles[2], help="leg-angle grid points")
    args = ap.parse_args(argv)
    print("reproduce with: python " + " ".join(shlex.quote(a) for a in [sys.argv[0]] + (argv or sys.argv[1:])))

    params = SlipParams()
    data = replace(DataConfig(), angles=(DataConfig.angles[0], DataConfig.angles[1], args.angles))
    t0 = time.perf_counter()
    feats, theta = make_dataset(params, data, seed=args.seed)
    print(f"{len(theta)} touchdowns simulated in {time.perf_counter() - t0:.1f} s")
    config = ControllerConfig(hidden=args.hidden, layers=args.layers)
    t0 = time.perf_counter()
    controller = train(feats, theta, params, config, replace(TrainConfig(), epochs=args.epochs), seed=args.seed)
    print(f"trained in {time.perf_counter() - t0:.0f} s")
    # the training data was simulated from x = 0 over flat ground at the landing level, 0
    pred = controller.leg_angles(np.stack([np.zeros(len(theta)), feats[:, 1], feats[:, 0]], 1), feats[:, 2],
                                 Terrain.flat(0.0, x0=-5.0, length=20.0), refine=False)
    err = np.abs(pred - theta)
    print(f"angle error on the training grid: median {np.median(err):.2e}, p99 {np.quantile(err, 0.99):.2e}, "
          f"max {err.max():.2e} rad")
    controller.save(args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
