"""Foothold error of the step-length controller on flat and stepped terrain.

    python3 examples/controller_accuracy.py --samples 20000 --drake 40 --seed 0

Targets are footholds the hopper really reaches: random apex states (0.5-3 m/s, 0.7-1.2 m above the ground)
and leg angles are simulated with the fast step map and the successful touchdowns kept. The controller is
then asked for each of those footholds and its leg angle simulated again: the error is |landed - target|.
A random subset is re-run on the Drake simulator to confirm (--drake 0: none). --hopper measures the controller for
another hopper (``StepLengthController.for_params``: the same network in the hopper's units), on the same terrains,
apexes and errors made the hopper's (lengths times its leg length over 0.5 m, speeds times sqrt(g L0) over the
paper's, apex heights also by how much less of a drop its spring takes, leg angles by its friction cone over the
paper's: ``planners.formats.suite_draw.start_height_factor``, as suites drawn for it start).

Exit status: 0 when the measurement ran, 2 for a usage or input error (e.g. a damaged weights file),
3 a simulation crashed (one line naming what failed: drakeslip/jobs/cli.py).
"""
from __future__ import annotations

import math
import sys

from drakeslip.jobs import cli  # before numpy: a Ctrl-C while it loads is one line (drakeslip/jobs/cli.py)
from drakeslip import cli_physics

import numpy as np

from drakeslip import SlipParams, Terrain, step_world
from drakeslip.controller import DEFAULT_WEIGHTS, StepLengthController

N_STEPPED = 10  # stepped terrain: step_world seeds 0..9, the samples spread over them


def targets(terrain, params, n: int, rng):
    from drakeslip import step_batch
    from drakeslip.units import PAPER, units_of
    from planners.formats.suite_draw import start_height_factor

    units = units_of(params)
    drop = units.length * start_height_factor(params, 1.2)
    cone = math.atan(params.friction) / math.atan(PAPER.friction)
    x = rng.uniform(-1.0, 15.0, n) * units.length
    apex = np.stack([x, terrain.height_at(x) + rng.uniform(0.7, 1.2, n) * drop,
                     rng.uniform(0.5, 3.0, n) * units.speed], axis=1)
    res = step_batch(apex, rng.uniform(-0.6, 0.6, n) * cone, terrain, params, parallel=True)
    return apex[res.ok], res.touchdown_x[res.ok]


def stats(err) -> str:
    """Error quantiles over the targets the foot landed near; a touchdown that never happened (the foot met a
    step face or tripped) or landed 5 cm or more away is counted as a miss instead."""
    err = np.asarray(err)
    hit = err < 0.05
    e = err[hit]
    misses = f"misses {np.count_nonzero(~hit)}/{err.size}"
    if e.size == 0:
        return f"no target hit within 5 cm   {misses}"
    return (f"median {1e3 * np.median(e):9.3g} mm   p90 {1e3 * np.quantile(e, 0.9):9.3g} mm   "
            f"max {1e3 * e.max():9.3g} mm   {misses}")


@cli_physics.reports_crashes
def main(argv=None) -> int:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--controller", type=cli.input_file, default=DEFAULT_WEIGHTS,
                    help="controller weights file (default: the committed drakeslip/weights/controller.pt)")
    cli_physics.add_hopper_argument(ap)
    ap.add_argument("--samples", type=cli.integer(N_STEPPED), default=20000,
                    help=f"random hops per terrain kind, before keeping the successful ones (at least {N_STEPPED}: "
                         f"the stepped kind spreads them over {N_STEPPED} terrains)")
    ap.add_argument("--drake", type=cli.non_negative_int, default=40,
                    help="targets per terrain kind re-run on the Drake simulator (0: none)")
    ap.add_argument("--seed", type=cli.non_negative_int, default=0, help="seed of the random apexes and leg angles")
    args = ap.parse_args(argv)

    try:
        controller = StepLengthController.load(args.controller)
    except (OSError, ValueError) as error:  # a damaged or mismatched weights file
        ap.error(f"--controller: {error}")
    cli.announce(argv)

    from drakeslip import step, step_batch  # the step maps: numba, and pydrake for the Drake one

    from drakeslip.terrain_file import scaled_terrain
    from drakeslip.units import units_of

    params = SlipParams() if args.hopper is None else args.hopper.params
    controller = controller.for_params(params)
    length = units_of(params).length
    rng = np.random.default_rng(args.seed)
    kinds = [("flat", [Terrain.flat(length=25.0)]),
             (f"stepped (step_world 0-{N_STEPPED - 1})", [step_world(s) for s in range(N_STEPPED)])]
    if length != 1.0:
        kinds = [(name, [scaled_terrain(t, length) for t in terrains]) for name, terrains in kinds]
    backends = ("fast", "drake") if args.drake else ("fast",)
    for name, terrains in kinds:
        cases = [(t, *targets(t, params, args.samples // len(terrains), rng)) for t in terrains]
        for backend in backends:
            for refine in (False, True):
                errors = []
                for t, apex, target in cases:
                    if backend == "drake":  # a few per terrain, spread over the terrains
                        k = -(-args.drake // len(terrains))
                        apex, target = apex[:k], target[:k]
                    theta = controller.leg_angles(apex, target, t, refine=refine)
                    if backend == "fast":
                        landed = step_batch(apex, theta, t, params, parallel=True).touchdown_x
                    else:
                        landed = np.array([step(a, th, t, params, backend="drake").touchdown_x
                                           for a, th in zip(apex, theta)])
                    errors.append(np.abs(np.nan_to_num(landed, nan=np.inf) - target))
                label = f"{name:<25} {backend:<5} {'refined' if refine else 'MLP only':<8}"
                print(f"{label} {stats(np.concatenate(errors))}")
    return cli.OK


if __name__ == "__main__":
    sys.exit(main())
