"""Retrain the step-length controller and write its weights (default: the committed drakeslip/weights/controller.pt).

    python3 examples/train_controller.py --seed 0 --epochs 300 --out out/controller.pt [--device cuda]

The training data is a jittered grid of apex speeds, heights, ground differences and leg angles simulated with the
fast step map (drakeslip/controller_training.py); the weights are written atomically when training is done, and
the SHA256SUMS manifest of the folder written to, if it has one, gets the new file's digest.

Exit status: 0 when the weights were written, 2 for a usage error (an unavailable --device among them).
"""
from __future__ import annotations

import sys
import time
from dataclasses import replace

from drakeslip.jobs import cli
from drakeslip.controller import DEFAULT_WEIGHTS, ControllerConfig
from drakeslip.controller_training import DataConfig, TrainConfig
from drakeslip.devices import DEVICE_HELP, torch_device


def main(argv=None) -> int:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--out", type=cli.output_file(".pt"), default=DEFAULT_WEIGHTS,
                    help="weights file to write (atomically)")
    ap.add_argument("--seed", type=cli.non_negative_int, default=0,
                    help="seeds the grid jitter, the train/validation split and the network")
    ap.add_argument("--epochs", type=cli.positive_int, default=TrainConfig.epochs, help="training epochs")
    ap.add_argument("--hidden", type=cli.positive_int, default=ControllerConfig.hidden, help="units per hidden layer")
    ap.add_argument("--layers", type=cli.positive_int, default=ControllerConfig.layers, help="hidden layers")
    ap.add_argument("--angles", type=cli.positive_int, default=DataConfig.angles[2],
                    help=f"leg-angle grid points over [{DataConfig.angles[0]}, {DataConfig.angles[1]}] rad")
    ap.add_argument("--device", default="auto", help=DEVICE_HELP)
    ap.add_argument("--quiet", action="store_true", help="no per-epoch progress lines")
    args = ap.parse_args(argv)
    try:
        device = torch_device(args.device)
    except ValueError as error:
        ap.error(f"--device: {error}")
    cli.announce(argv)

    import numpy as np

    from drakeslip import SlipParams, Terrain
    from drakeslip.controller_training import make_dataset, train

    params = SlipParams()
    data = replace(DataConfig(), angles=(DataConfig.angles[0], DataConfig.angles[1], args.angles))
    t0 = time.perf_counter()
    feats, theta = make_dataset(params, data, seed=args.seed)
    print(f"{len(theta)} touchdowns simulated in {time.perf_counter() - t0:.1f} s")
    config = ControllerConfig(hidden=args.hidden, layers=args.layers)
    t0 = time.perf_counter()
    log = (lambda *_, **__: None) if args.quiet else print
    controller = train(feats, theta, params, config, replace(TrainConfig(), epochs=args.epochs), seed=args.seed,
                       log=log, device=device)
    print(f"trained in {time.perf_counter() - t0:.0f} s on {device}")
    # the training data was simulated from x = 0 over flat ground at the landing level, 0
    pred = controller.leg_angles(np.stack([np.zeros(len(theta)), feats[:, 1], feats[:, 0]], 1), feats[:, 2],
                                 Terrain.flat(0.0, x0=-5.0, length=20.0), refine=False)
    err = np.abs(pred - theta)
    print(f"angle error on the training grid: median {np.median(err):.2e}, p99 {np.quantile(err, 0.99):.2e}, "
          f"max {err.max():.2e} rad")
    controller.save(args.out)
    print(f"wrote {args.out}")
    return cli.OK


if __name__ == "__main__":
    sys.exit(main())
