"""The paper's Tables II and III for all five planners (and LSTM-guided beyond the paper), with our numbers next
to the paper's and their ratio.

    python3 examples/paper_tables.py --jobs 2 --markdown docs/paper_tables.md

Runs the receding-horizon evaluation (planners/evaluation.py: plan on the window with the fast step map,
execute 3 footholds on the Drake simulator, replan) on the committed suites, ditch (Table II) and step
(Table III), plus any --extra suites (e.g. a mixed one), writes each suite's results JSON into --out-dir
(resumable: a killed run continues from its per-case cache) and prints the tables as markdown.
"""
from __future__ import annotations

import argparse
import os
import shlex
import sys
from pathlib import Path

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from drakeslip.files import atomic_write  # noqa: E402
from planners import planner_name  # noqa: E402
from planners.evaluation import EvalConfig, evaluate, make_planners, write_json  # noqa: E402
from planners.suite import load_suite  # noqa: E402

# Beyond the paper (planners/presets.py): the LSTM mode one step ahead with the model trained on the goal-reaching
# expert, the same with the learned re-ranker of its five most probable first footholds, and LSTM-guided with the
# sub-cell model, simulating one sampled child at a time and restarting the model from each node's apex.
BEYOND = ("lstm@dagger", "lstm@ranked", "lstm-guided@beyond")
PLANNERS = ("heuristic", "angle", "step", "lstm", "lstm-guided", *BEYOND)
LABELS = {"heuristic": "Heuristic", "angle": "Angle-space", "step": "Step-space", "lstm": "LSTM",
          "lstm-guided": "LSTM-Guided", "lstm@dagger": "LSTM, beyond the paper",
          "lstm@ranked": "LSTM + learned re-ranker, beyond the paper",
          "lstm-guided@beyond": "LSTM-Guided, beyond the paper"}
# The paper's Tables II (ditch) and III (step): success %, ODE calls, t_plan [s].
PAPER = {
    "ditch": {"heuristic": (24, 0, 2e-5), "angle": (58.6, 22661, 0.15), "step": (86.6, 30857, 0.29),
              "lstm": (56, 0, 0.007), "lstm-guided": (84, 4885, 0.04)},
    "step": {"heuristic": (56, 0, 2e-5), "angle": (60, 27021, 0.15), "step": (85, 41146, 0.34),
             "lstm": (49, 0, 0.007), "lstm-guided": (96, 6932, 0.04)},
}


def ratio(ours: float, paper: float) -> str:
    return f"{ours / paper:.2f}x" if paper else "-"


def markdown(results: dict, paper: dict | None) -> str:
    """One table: our success, ODE calls and planning time per call, and (where the paper has the suite) the
    paper's numbers and ours / paper."""
    head = ("| Planner | Success % | ODE calls / plan | t_plan mean | t_plan median | nodes expanded / plan | "
            "footholds / plan | Step-space's ODE calls / this |")
    rule = "|---|---|---|---|---|---|---|---|"
    if paper:
        head += " paper: Success % / ODE calls / t_plan | ratio ours/paper: success / ODE calls / t_plan |"
        rule += "---|---|"
    rows = [f"**{results['suite']}** ({len(next(iter(results['planners'].values()))['cases'])} cases)", "",
            head, rule]
    step = results["planners"].get("step")
    for name, r in results["planners"].items():
        ours = (100 * r["success_rate"], r["ode_calls_mean"], r["t_plan_mean_s"])
        vs_step = f"{step['ode_calls_mean'] / r['ode_calls_mean']:.1f}" if step and r["ode_calls_mean"] else "-"
        row = (f"| {LABELS.get(name, name)} | {ours[0]:.1f} | {ours[1]:.0f} | {ours[2] * 1e3:.2f} ms | "
               f"{r['t_plan_median_s'] * 1e3:.2f} ms | {r['nodes_expanded_mean']:.1f} | {r['footholds_mean']:.1f} | "
               f"{vs_step} |")
        if paper:
            p = paper[planner_name(name)]
            row += (f" {p[0]} / {p[1]} / {p[2]:g} s | {ratio(ours[0], p[0])} / {ratio(ours[1], p[1])} / "
                    f"{ratio(ours[2], p[2])} |")
        rows.append(row)
    return "\n".join(rows)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ditch", default="suites/ditch.json", help="Table II's suite")
    ap.add_argument("--step", default="suites/step.json", help="Table III's suite")
    ap.add_argument("--extra", default="", help="comma-separated further suites (no paper numbers)")
    ap.add_argument("--planners", default=",".join(PLANNERS))
    ap.add_argument("--cases", type=int, default=None, help="only the first N cases of each suite")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--backend", default="drake", choices=("drake", "fast"), help="where plans are executed")
    ap.add_argument("--out-dir", default="out/tables")
    ap.add_argument("--markdown", default=None, help="also write the tables to this file")
    args = ap.parse_args(argv)
    command = "python3 examples/paper_tables.py " + " ".join(shlex.quote(a) for a in (argv or sys.argv[1:]))
    names = [n for n in args.planners.split(",") if n]
    if not names or (args.cases is not None and args.cases < 1) or args.jobs < 1:
        ap.error(f"need planners, --cases >= 1 and --jobs >= 1, got {args.planners!r}, {args.cases}, {args.jobs}")
    try:  # an unknown planner or bad option is refused before any suite runs
        make_planners({n: {} for n in names})
    except ValueError as error:
        ap.error(str(error))
    Path(args.out_dir).mkdir(parents=True, exist_ok=True)
    sections = [f"Made by `{command}`; execution on the {args.backend} backend."]
    paths = [("ditch", args.ditch), ("step", args.step)] + [(None, p) for p in args.extra.split(",") if p]
    try:  # every suite is read before the first is evaluated: a malformed last one must not cost an hour
        suites = [(family, load_suite(path)) for family, path in paths]
    except (OSError, ValueError) as error:
        ap.error(str(error))
    for family, suite in suites:
        out = Path(args.out_dir) / f"results-{suite.name}.json"
        results = evaluate(suite, {n: {} for n in names}, n_cases=args.cases, jobs=args.jobs,
                           cache_path=str(out) + ".cases.jsonl", config=EvalConfig(backend=args.backend))
        write_json(results, out)
        title = {"ditch": "Table II (ditch suite)", "step": "Table III (step suite)"}.get(family, suite.name)
        sections.append(f"### {title}\n\n" + markdown(results, PAPER.get(family)))
    text = "\n\n".join(sections) + "\n"
    print(text)
    if args.markdown:
        with atomic_write(args.markdown, "w") as f:
            f.write(text)
        print(f"wrote {args.markdown}")


if __name__ == "__main__":
    main()
