r"""Figures of evaluation results (results JSONs of examples/evaluate.py or examples/paper_tables.py), as PNGs.

    python3 examples/plot_results.py out/ditch.json out/step.json --out out/figs

writes OUT/success.png (success rate per planner and run with 95 % Wilson intervals, the paper's Table II/III values
marked for the ditch and step suites) and OUT/cost.png (ODE calls and planning time per planning call, log scales),
and, when the planners account for their time (the compiled core's ``Plan.timing``), OUT/timing.png: the mean time
per planning call in the step map, the controller, the footstep model and the search. When the inputs were run with
different noise scales (evaluate.py --noise realistic*K), it also writes OUT/noise.png: success against K, one line
per planner with its 95 % band:

    for k in 0 0.25 0.5 1 2; do python3 examples/evaluate.py --suite suites/ditch.json --planners step \
        --cases 20 --noise "realistic*$k" --out out/noise-$k.json; done
    python3 examples/plot_results.py out/noise-*.json --out out/figs

Exit status: 0 the figures were written, 2 a usage or input error (a file that is not a results JSON).
"""
from __future__ import annotations

import sys

from drakeslip.jobs import cli
from drakeslip.jobs.files import read_json


def load_results(path) -> dict:
    """A results JSON of verification.evaluation.evaluate; a ValueError naming the file otherwise."""
    results = read_json(path, "results file")
    planners = results.get("planners") if isinstance(results, dict) else None
    if not isinstance(planners, dict) or not planners or "suite" not in results or not all(
            isinstance(b, dict) and {"config", "cases", "success_interval"} <= set(b) for b in planners.values()):
        raise ValueError(f"{path} is not a results file of examples/evaluate.py (no 'suite' and 'planners' with "
                         "'config', 'cases' and 'success_interval')")
    return results


def order(results: dict) -> tuple:
    """Runs in the figures' legends by suite, then noise scale (realistic*K; other noise last), then backend."""
    from verification.plots import noise_scale

    config = next(iter(results["planners"].values()))["config"]
    k = noise_scale(config["noise"])
    return results["suite"], float("inf") if k is None else k, config["backend"]


def main(argv=None) -> int:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("results", nargs="+", type=cli.input_file, help="results JSON files of examples/evaluate.py")
    ap.add_argument("--out", type=cli.output_folder, default="out/figs", help="folder the PNGs are written to")
    ap.add_argument("--no-paper", action="store_true", help="do not mark the paper's values")
    args = ap.parse_args(argv)
    try:
        runs = sorted((load_results(path) for path in args.results), key=order)
    except (OSError, ValueError) as error:
        ap.error(str(error))

    from verification.paper import TABLES
    from verification.plots import cost_figure, noise_figure, noise_runs, success_figure, timing_figure

    written = [success_figure(runs, args.out / "success.png", None if args.no_paper else TABLES),
               cost_figure(runs, args.out / "cost.png")]
    timing = timing_figure(runs, args.out / "timing.png")  # None when no planner accounts for its time
    if timing is not None:
        written.append(timing)
    if any(len({k for k, _, _ in rows}) > 1 for rows in noise_runs(runs).values()):
        written.append(noise_figure(runs, args.out / "noise.png"))
    for path in written:
        print(f"wrote {path}")
    return cli.OK


if __name__ == "__main__":
    sys.exit(main())
