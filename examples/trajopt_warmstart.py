r"""Trajectory optimization from different seeds: converged / Drake-verified rates, solve time, iterations.

    python3 examples/make_suites.py --families step --seed 7000 --out out/fresh
    python3 examples/trajopt_warmstart.py --suite out/fresh/step-7000.json --every 7 \
        --seeds cold,heuristic,step,lstm --out out/trajopt-step-7000.json

A seed is a planner label, NAME or NAME@VARIANT: a preset (lstm@paper, lstm-guided@paper: the paper's settings;
plain lstm and lstm-guided are the best shipped ones), or any variant with options for its planner keyed by that
label, so two settings of one seed run side by side:

    python3 examples/trajopt_warmstart.py --suite out/fresh/step-9000.json --every 3 --cases 50 \
        --seeds cold,lstm-guided,lstm-guided@expert --out out/trajopt-expert.json \
        --options '{"lstm-guided@expert": {"model": "planners/weights/lstm_expert.pt", "lazy": true,
                    "conditioning": "apex"}}'

Each case is one planning query, the perception-window problem of the case's start apex toward the suite's goal
(the target is 1 m short of the window's far edge, as for every planner). Each seed proposes footholds on the
window; they fix the segment of every hop; SNOPT optimizes the N hops (planners/trajopt/); the optimized leg
angles are simulated open loop on the Drake hybrid simulator on the true terrain. ``verified`` = the solver
converged and Drake completes all N hops with no failure, past the target; a solve that fails is a result, not
an error. Finished (seed, case) solves are stored in OUT.cases.jsonl, keyed by everything a record depends on
(the code version: the git commit and a digest of uncommitted changes, or a digest of the packages outside a git
checkout; the settings, the seed and its options, the SHA-256 of every weights file the seed reads, the case), so
a killed run continues where it stopped and a run of changed code solves again (--no-resume starts over).
--jobs N solves N (seed, case) pairs at a time in separate processes (or on a Ray cluster with --executor ray),
with the same records as one process (solve times are wall-clock: keep N at most the number of cores).

Exit status: 0 when the solves ran (whatever their outcomes), 2 for a usage or input error, 3 a simulation crashed
(one line naming what failed: drakeslip/jobs/cli.py).
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # small matrices: threaded BLAS only contends for the cores

import argparse
import hashlib
import json
import statistics
from dataclasses import asdict
from pathlib import Path

from drakeslip.jobs import cli
from drakeslip import cli_physics
from drakeslip.jobs.files import sha256
from planners.registry import label_options, planner_name
from planners.trajopt.config import COLLOCATIONS, SEEDS, TrajoptConfig

FORMAT = "drakeslip-trajopt-warmstart/1"
RECORD_FIELDS = ("converged", "verified")   # of a stored solve; one lacking either is solved again


def seed_labels(text: str) -> list[str]:
    """An argument type: comma-separated seed labels, each a seed or NAME@VARIANT of one."""
    labels = cli.names(text)
    for label in labels:
        if planner_name(label) not in SEEDS:
            raise argparse.ArgumentTypeError(f"unknown seed {label!r}; known seeds: {', '.join(SEEDS)} "
                                             "(each optionally NAME@VARIANT)")
    if len(set(labels)) < len(labels):
        raise argparse.ArgumentTypeError(f"a seed is named twice in {text!r}")
    return labels


def parser() -> cli.ArgumentParser:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--suite", required=True, type=cli.input_file, help="suite JSON file (format drakeslip-suite/1)")
    cli_physics.add_hopper_argument(ap, default="the suite's; another is refused in one line")
    ap.add_argument("--cases", type=cli.positive_int, default=None,
                    help="how many of the selected cases (None: all)")
    ap.add_argument("--every", type=cli.positive_int, default=1,
                    help="take every K-th case of the suite (suites list 10 starts per terrain: K = 7 spreads "
                         "the cases over every terrain and every start)")
    ap.add_argument("--seeds", type=seed_labels, default="cold,heuristic,step,lstm",
                    help=f"comma-separated, of {', '.join(SEEDS)}, each optionally NAME@VARIANT")
    ap.add_argument("--options", default="{}",
                    help="options for the seeds' planners as JSON keyed by seed label, e.g. "
                         '\'{"lstm-guided@lazy": {"lazy": true}}\'')
    ap.add_argument("--out", required=True, type=cli.output_file(".json", beside=(".cases.jsonl",)),
                    help="results JSON (written atomically); the solves are stored beside it in OUT.cases.jsonl")
    ap.add_argument("--knots", type=cli.integer(2), default=TrajoptConfig.knots,
                    help="stance knots per hop minus one")
    ap.add_argument("--collocation", default=TrajoptConfig.collocation, choices=COLLOCATIONS,
                    help="stance transcription")
    ap.add_argument("--max-hops", type=cli.positive_int, default=TrajoptConfig.max_hops,
                    help="a seed's footholds beyond this many are dropped")
    ap.add_argument("--starts", type=cli.positive_int, default=TrajoptConfig.starts,
                    help="starts per case for the seeds that have several (cold: other strides; lstm-guided: other "
                         "samples), tried until one is verified")
    ap.add_argument("--solver", default=TrajoptConfig.solver, choices=("snopt", "ipopt"),
                    help="snopt falls back to ipopt where it is unavailable")
    ap.add_argument("--seed-model", type=cli.input_file, default=None,
                    help="checkpoint for the lstm and lstm-guided seeds (None: each seed label's own)")
    cli.add_parallel(ap)
    ap.add_argument("--plot", type=cli.output_file(".png"), default=None,
                    help="also draw the first case: each seed's footholds and the optimized leg angles run on Drake, "
                         "and the optimizer's footholds and apexes, over the terrain (PNG)")
    ap.add_argument("--no-resume", action="store_true", help="ignore and replace the stored solves")
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    return ap


def seed_files(seed: str, options: dict | None, config: TrajoptConfig) -> dict:
    """The weights files the seed's planner reads (the trajopt planner's ``files_read``), with their digests."""
    from planners.registry import files_read

    files = files_read("trajopt", {"seed": seed, "seed_options": options, "config": config})
    return {name: [path, sha256(path)] for name, path in sorted(files.items())}


def summarize(cases: list) -> dict:
    """One seed's block: rates over all cases; solve time and iterations over the cases that reached the solver."""
    solved = [c for c in cases if c.get("solve_time_s") is not None]
    iters = [c["iterations"] for c in solved if c.get("iterations") is not None]
    n = len(cases)
    return {"cases_n": n,
            "converged_rate": sum(c["converged"] for c in cases) / n if n else 0.0,
            "verified_rate": sum(c["verified"] for c in cases) / n if n else 0.0,
            "first_start_verified_rate": sum(c["starts"][0]["verified"] if "starts" in c else c["verified"]
                                             for c in cases) / n if n else 0.0,
            "drake_ok_rate": sum(bool(c.get("drake_ok")) for c in cases) / n if n else 0.0,
            "seed_fast_ok_rate": sum(bool(c.get("seed_fast_ok")) for c in cases) / n if n else 0.0,
            "seed_errors": sum(c.get("error") is not None for c in cases),
            "solve_time_median_s": statistics.median(c["solve_time_s"] for c in solved) if solved else None,
            "solve_time_mean_s": statistics.fmean(c["solve_time_s"] for c in solved) if solved else None,
            "iterations_median": statistics.median(iters) if iters else None,
            "hops_median": statistics.median(c["hops"] for c in solved) if solved else None,
            "cases": cases}


def table(results: dict) -> str:
    fmt = lambda v, spec: "-" if v is None else format(v, spec)
    w = max(11, *(len(name) for name in results["seeds"]))
    rows = [f"Trajectory optimization on {results['suite']} ({results['cases_n']} cases)",
            f"{'seed':<{w}} {'converged %':>11} {'verified %':>10} {'1st start %':>11} {'drake ok %':>10} "
            f"{'seed ok %':>9} {'no seed':>7} {'solve median':>12} {'iters median':>12} {'hops median':>11}"]
    for name, r in results["seeds"].items():
        rows.append(f"{name:<{w}} {100 * r['converged_rate']:>11.1f} {100 * r['verified_rate']:>10.1f} "
                    f"{100 * r['first_start_verified_rate']:>11.1f} {100 * r['drake_ok_rate']:>10.1f} "
                    f"{100 * r['seed_fast_ok_rate']:>9.1f} {r['seed_errors']:>7d} "
                    f"{fmt(r['solve_time_median_s'], '.2f'):>11}s {fmt(r['iterations_median'], 'g'):>12} "
                    f"{fmt(r['hops_median'], 'g'):>11}")
    rows.append("verified: converged and Drake completes the hops open loop past the target (by any start); "
                "1st start: verified from the seed's first start; drake ok: Drake alone (converged or not); seed "
                "ok: the seed's own footholds execute on the fast step map; solve: all starts' solver time")
    return "\n".join(rows)


def checked_inputs(ap: cli.ArgumentParser, args):
    """(the suite, its hopper, the solver's config, the seeds' options, the weights files each seed reads), the seeds'
    planners built; or one line and exit status 2 for bad settings, options, suite, hopper or weights."""
    def refuse(error):  # one line on stderr, exit status 2
        ap.error(" ".join(str(error).split()))

    if args.executor == "local" and args.address is not None:
        refuse("--address is for --executor ray")
    seeds = args.seeds
    try:
        config = TrajoptConfig(knots=args.knots, collocation=args.collocation, max_hops=args.max_hops,
                               solver=args.solver, starts=args.starts,
                               seed_model=str(args.seed_model) if args.seed_model else None)
        options = label_options(args.options, seeds, kind="seed")
    except ValueError as error:
        refuse(error)
    from planners.formats.suite import load_suite

    from planners.formats.suite_draw import hopper_for_suite
    from planners.registry import hopper_options

    try:
        suite = load_suite(args.suite)
        hopper = hopper_for_suite(suite, args.hopper)   # the suite's hopper; a folder's weights seed the solves
        options = {s: o for s in seeds if (o := hopper_options(s, options.get(s), hopper)) is not None}
    except (OSError, ValueError) as error:  # an unreadable or malformed suite file, another hopper's suite
        refuse(error)
    # the seeds' planners are built (and kept for the solves in this process): bad options or weights stop here
    from planners.trajopt.seeds import check_seed

    try:
        for seed in seeds:
            check_seed(seed, options.get(seed), config)
        files = {seed: seed_files(seed, options.get(seed), config) for seed in seeds}
    except (OSError, ValueError) as error:
        refuse(error)
    return suite, hopper, config, options, files


def solved(tasks: list, pairs: dict, cases: list, store, executor, args, desc: str) -> dict:
    """{seed: its record of each case, in the cases' order}: the tasks run (or read from ``store``)."""
    from tqdm import tqdm

    from drakeslip.jobs.runner import run
    from planners.trajopt.solve import optimize

    seeds, records = args.seeds, {}
    with tqdm(total=len(tasks), disable=args.quiet, unit="solve", desc=desc) as bar:
        for k, result in run(optimize, tasks, store, executor):
            s, i = pairs[k]
            records[(s, i)] = {"id": cases[i].id, **result}
            bar.update(1)
            bar.set_postfix({n: sum(r["verified"] for (m, _), r in records.items() if m == n) for n in seeds})
    return {s: [records[(s, i)] for i in range(len(cases))] for s in seeds}


@cli_physics.reports_crashes
def main(argv=None) -> int:
    ap = parser()
    args = ap.parse_args(argv)
    suite, hopper, config, options, files = checked_inputs(ap, args)
    seeds = args.seeds
    executor = cli.executor(args)
    cli.announce(argv)

    from drakeslip.jobs.runner import JsonLinesStore, has_fields, remove, write_json
    from drakeslip.units import units_of
    from planners.trajopt.planner import make_problem
    from verification.provenance import code_version, provenance

    cases = list(suite.cases[::args.every])[:args.cases]
    params = hopper.params.with_friction(suite.friction)
    code = code_version()   # the version the keys hold is the one the results file names
    # the paper's hopper is left out of the key, so its cached solves stay valid
    setup = [FORMAT, asdict(config), code, suite.goal_x, suite.friction, *([asdict(params)] if suite.hopper else [])]

    def key(seed, case) -> str:
        return hashlib.sha256(json.dumps([setup, seed, options.get(seed, {}), files[seed], case.id,
                                          case.terrain.to_dict(), list(case.apex)], sort_keys=True,
                                         default=str).encode()).hexdigest()[:20]

    store_path = Path(str(args.out) + ".cases.jsonl")
    if args.no_resume:
        remove(store_path)
    window = units_of(params).window
    problems = [make_problem(case.apex, case.terrain.perceived(case.apex.x, *window), suite.goal_x, params)
                for case in cases]
    pairs = {key(s, case): (s, i) for i, case in enumerate(cases) for s in seeds}  # case ids are unique
    # case-major: every seed sees the same cases at any point of a partial run
    tasks = [(k, (problems[i], s, config, cases[i].terrain, True, options.get(s)))  # True: verify on Drake
             for k, (s, i) in pairs.items()]
    store = JsonLinesStore(store_path, has_fields(*RECORD_FIELDS), code)
    done = solved(tasks, pairs, cases, store, executor, args, suite.name)
    results = {"format": FORMAT, "suite": suite.name, "suite_file": str(args.suite), "hopper": hopper.to_record(),
               "cases_n": len(cases),
               "every": args.every, "config": asdict(config), "options": options, "weights": files,
               "provenance": provenance(code), "seeds": {s: summarize(done[s]) for s in seeds}}
    write_json(args.out, results)
    print(table(results))
    print(f"wrote {args.out}")
    if args.plot and cases:
        plot_case(cases[0], {s: done[s][0] for s in seeds}, params, suite.name, args.plot)
    return cli.OK


def plot_case(case, records: dict, params, suite_name: str, path) -> None:
    """``verification.plots.trajopt_figure`` of one case: per seed, its footholds through the controller and the
    optimized leg angles open loop, both logged on Drake."""
    from drakeslip import StepLengthController
    from drakeslip.rollout import rollout
    from verification.plots import trajopt_figure

    controller = StepLengthController.load_default()
    panels = []
    for seed, r in records.items():
        seed_sim = drake_sim = None
        if r.get("seed_footholds"):
            seed_sim = rollout(case.apex, case.terrain, params, footholds=r["seed_footholds"],
                               controller=controller, log=True).simulation
        if r.get("leg_angles"):
            drake_sim = rollout(case.apex, case.terrain, params, leg_angles=r["leg_angles"], log=True).simulation
        panels.append({"seed": seed, "record": r, "seed_sim": seed_sim, "drake_sim": drake_sim})
    title = f"trajopt_warmstart.py: seed vs optimized vs Drake rollout, {suite_name} case {case.id}"
    print(f"figure: {trajopt_figure(case.terrain, panels, path, title)}")


if __name__ == "__main__":
    raise SystemExit(main())
