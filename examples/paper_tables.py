"""The paper's Tables II and III: every planner, the paper's literal settings (@paper) and the defaults side by
side, with our numbers next to the paper's and their ratio.

    python3 examples/paper_tables.py --jobs 2 --out out/tables --markdown docs/paper_tables.md

Runs the receding-horizon evaluation (verification/evaluation.py: plan on the window with the fast step map,
execute 3 footholds on the Drake simulator, replan) on the committed suites, ditch (Table II) and step
(Table III), plus any --extra suites (e.g. a mixed one), writes each suite's results JSON into the --out folder
(resumable: a killed run continues from its per-case cache) and prints the tables as markdown.

Exit status: 0 when the tables were made, 2 for a usage or input error, 3 a simulation crashed (one line naming what
failed: drakeslip/jobs/cli.py).
"""
from __future__ import annotations

import shlex
import sys
from pathlib import Path

from drakeslip.jobs import cli
from drakeslip import cli_physics
from planners.registry import check_label, planner_name
from verification.paper import TABLES, TITLES, reported

PLANNERS = ("heuristic", "angle", "step", "lstm@paper", "lstm-guided@paper", "lstm@no-ranker", "lstm", "lstm-guided")
LABELS = {"heuristic": "Heuristic", "angle": "Angle-space", "step": "Step-space",
          "lstm@paper": "LSTM (@paper: the paper's model and settings)",
          "lstm-guided@paper": "LSTM-Guided (@paper: the paper's model and settings)",
          "lstm@no-ranker": "LSTM, expert-trained model, no re-ranker",
          "lstm": "LSTM (default: expert-trained model, learned re-ranker)",
          "lstm-guided": "LSTM-Guided (default: sub-cell model, lazy, apex-conditioned)"}


def ratio(ours: float, paper: float) -> str:
    return f"{ours / paper:.2f}x" if paper else "-"


def markdown(results: dict, family: str | None) -> str:
    """One table: our success (with its 95 % interval), ODE calls and planning time per call, and, for the
    paper's suite ``family`` (None: another suite), the paper's numbers and ours / paper ("-" for a planner the
    paper did not run)."""
    paper = family in TABLES
    head = ("| Planner | Success % (95 % interval) | ODE calls / plan | t_plan mean | t_plan median | "
            "nodes expanded / plan | footholds / plan | Step-space's ODE calls / this |")
    rule = "|---|---|---|---|---|---|---|---|"
    if paper:
        head += " paper: Success % / ODE calls / t_plan | ratio ours/paper: success / ODE calls / t_plan |"
        rule += "---|---|"
    rows = [f"**{results['suite']}** ({len(next(iter(results['planners'].values()))['cases'])} cases)", "",
            head, rule]
    step = results["planners"].get("step")
    for name, r in results["planners"].items():
        ours = (100 * r["success_rate"], r["ode_calls_mean"], r["t_plan_mean_s"])
        lo, hi = (100 * v for v in r["success_interval"])
        vs_step = f"{step['ode_calls_mean'] / r['ode_calls_mean']:.1f}" if step and r["ode_calls_mean"] else "-"
        row = (f"| {LABELS.get(name, name)} | {ours[0]:.1f} ({lo:.1f}-{hi:.1f}) | {ours[1]:.0f} | "
               f"{ours[2] * 1e3:.2f} ms | {r['t_plan_median_s'] * 1e3:.2f} ms | {r['nodes_expanded_mean']:.1f} | "
               f"{r['footholds_mean']:.1f} | {vs_step} |")
        p = reported(family, planner_name(name))
        if paper:
            row += " - | - |" if p is None else (f" {p[0]} / {p[1]} / {p[2]:g} s | {ratio(ours[0], p[0])} / "
                                                 f"{ratio(ours[1], p[1])} / {ratio(ours[2], p[2])} |")
        rows.append(row)
    return "\n".join(rows)


def suite_files(text: str) -> list:
    """An argument type: comma-separated suite files, each one that exists."""
    return [cli.input_file(name) for name in cli.names(text)]


@cli_physics.reports_crashes
def main(argv=None) -> int:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--ditch", type=cli.input_file, default="suites/ditch.json", help="Table II's suite")
    ap.add_argument("--step", type=cli.input_file, default="suites/step.json", help="Table III's suite")
    ap.add_argument("--extra", type=suite_files, default=[], help="further suites, comma-separated (no paper numbers)")
    ap.add_argument("--planners", type=cli.names, default=",".join(PLANNERS), help="planner labels, comma-separated")
    ap.add_argument("--cases", type=cli.positive_int, default=None, help="only the first N cases of each suite")
    ap.add_argument("--backend", default="drake", choices=("drake", "fast"), help="what executes the plans")
    ap.add_argument("--out", type=cli.output_folder, default="out/tables", help="folder of the results JSON files")
    ap.add_argument("--markdown", type=cli.output_file(".md"), default=None, help="also write the tables here")
    ap.add_argument("--quiet", action="store_true", help="no progress bars")
    cli.add_parallel(ap)
    args = ap.parse_args(argv)
    executor = cli.executor(args)

    from drakeslip.jobs.executors import prepare
    from drakeslip.jobs.files import atomic_write
    from drakeslip.jobs.runner import write_json
    from planners.closed_loop import ClosedLoopConfig
    from planners.formats.suite import load_suite
    from verification.evaluation import evaluate, worker_setup

    specs = {}
    try:  # an unknown planner, a bad option or a malformed suite is refused before any suite runs
        specs = {check_label(label): None for label in args.planners}
        prepare(worker_setup(specs))
        paths = [("ditch", args.ditch), ("step", args.step)] + [(None, path) for path in args.extra]
        suites = [(family, load_suite(path)) for family, path in paths]
    except (OSError, ValueError) as error:
        ap.error(str(error))
    names = [suite.name for _, suite in suites]
    if len(set(names)) < len(names):  # each suite's results go to OUT/results-NAME.json
        ap.error(f"two suites are named {max(names, key=names.count)!r}: their results files would overwrite each "
                 "other; give suites with different names")
    results_files = [Path(args.out) / f"results-{name}.json" for name in names]
    ap.check_outputs(args, [("--out", path) for out in results_files for path in (out, f"{out}.cases.jsonl")])
    cli.announce(argv)
    command = "python3 examples/paper_tables.py " + " ".join(shlex.quote(a) for a in (argv or sys.argv[1:]))
    sections = [f"Made by `{command}`; execution on the {args.backend} backend."]
    for family, suite in suites:
        out = Path(args.out) / f"results-{suite.name}.json"
        results = evaluate(suite, specs, n_cases=args.cases, executor=executor, cache_path=str(out) + ".cases.jsonl",
                           config=ClosedLoopConfig(backend=args.backend), progress=not args.quiet)
        write_json(out, results)
        sections.append(f"### {TITLES.get(family, suite.name)}\n\n" + markdown(results, family))
    text = "\n\n".join(sections) + "\n"
    print(text)
    if args.markdown:
        with atomic_write(args.markdown, "w") as f:
            f.write(text)
        print(f"wrote {args.markdown}")
    return cli.OK


if __name__ == "__main__":
    sys.exit(main())
