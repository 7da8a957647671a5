"""Trajectory optimization from different seeds (issue 5): converged / Drake-verified rates, solve time, iterations.

    python examples/make_suites.py --families step --seed 7000 --out-dir out/fresh
    python examples/trajopt_warmstart.py --suite out/fresh/step-7000.json --every 7 \\
        --seeds cold,heuristic,step,lstm --out out/trajopt-step-7000.json

A seed may be given as NAME@VARIANT, with options for its planner keyed by that label, so two settings of one
seed run side by side:

    python examples/trajopt_warmstart.py --suite out/fresh/step-9000.json --every 3 --cases 50 \\
        --seeds cold,lstm-guided,lstm-guided@expert --out out/trajopt-expert.json \\
        --options '{"lstm-guided@expert": {"weights": "planners/weights/lstm_expert.pt", "lazy": true,
                    "conditioning": "apex"}}'

Each case is one planning query, the perception-window problem of the case's start apex toward the suite's goal
(the target is 1 m short of the window's far edge, as for every planner). Each seed proposes footholds on the
window; they fix the segment of every hop; SNOPT optimizes the N hops (planners/trajopt.py); the optimized leg
angles are simulated open loop on the Drake hybrid simulator on the true terrain. ``verified`` = the solver
converged and Drake completes all N hops with no failure, past the target. Finished cases are cached in
OUT.cases.jsonl (keyed by the source and weights of drakeslip and planners, the settings and the LSTM checkpoint),
so a killed run continues where it stopped (--no-resume starts over). --jobs N solves N (seed, case) pairs at a
time in separate processes, with the same records as one process (solve times are wall-clock: keep N at most the
number of cores).
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # small matrices: threaded BLAS only contends for the cores

import argparse
import hashlib
import json
import shlex
import statistics
import sys
from dataclasses import asdict
from pathlib import Path

from drakeslip import SlipParams
from drakeslip.files import append_jsonl, atomic_write, open_jsonl_cache, read_jsonl_cache
from drakeslip.pool import results_of
from planners.evaluation import perceived
from planners.registry import label_options
from planners.suite import load_suite
from planners.trajopt import SEEDS, TrajoptConfig, check_seed, make_problem, optimize

FORMAT = "drakeslip-trajopt-warmstart/1"


def source_digest() -> str:
    """A digest of the packages' source and committed weights: a changed optimizer, seed planner, model or
    controller must not reuse cached cases."""
    import drakeslip
    import planners

    h = hashlib.sha256()
    for package in (Path(drakeslip.__file__).parent, Path(planners.__file__).parent):
        for f in sorted(package.rglob("*")):
            if f.suffix in (".py", ".pt") and "__pycache__" not in f.parts:
                h.update(f.relative_to(package.parent).as_posix().encode())
                h.update(f.read_bytes())
    return h.hexdigest()[:12]


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


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--suite", required=True, help="suite JSON file (format drakeslip-suite/1)")
    ap.add_argument("--cases", type=int, default=None, help="how many cases (default: all selected)")
    ap.add_argument("--every", type=int, default=1,
                    help="take every K-th case of the suite (suites list 10 starts per terrain: K = 7 spreads "
                         "the cases over every terrain and every start)")
    ap.add_argument("--seeds", default="cold,heuristic,step,lstm",
                    help=f"comma-separated, of {list(SEEDS)}, each optionally NAME@VARIANT")
    ap.add_argument("--options", default="{}",
                    help="options for the seeds' planners as JSON keyed by seed label, e.g. "
                         '\'{"lstm-guided@lazy": {"lazy": true}}\'')
    ap.add_argument("--out", required=True, help="results JSON (written atomically)")
    ap.add_argument("--knots", type=int, default=TrajoptConfig.knots, help="stance knots per hop minus one")
    ap.add_argument("--collocation", default=TrajoptConfig.collocation, choices=("chebyshev", "hermite-simpson"))
    ap.add_argument("--max-hops", type=int, default=TrajoptConfig.max_hops)
    ap.add_argument("--starts", type=int, default=TrajoptConfig.starts,
                    help="starts per case for the seeds that have several (cold: other strides; lstm-guided: other "
                         "samples), tried until one is verified")
    ap.add_argument("--solver", default="snopt", choices=("snopt", "ipopt"))
    ap.add_argument("--lstm-weights", default=None,
                    help="checkpoint for the lstm and lstm-guided seeds (default: the committed one)")
    ap.add_argument("--jobs", type=int, default=1,
                    help="solver processes (default 1; solve times are wall-clock, so keep it at most the cores)")
    ap.add_argument("--no-resume", action="store_true", help="ignore and replace the case cache")
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    args = ap.parse_args(argv)
    print("reproduce with: python " + " ".join(shlex.quote(a) for a in [sys.argv[0]] + (argv or sys.argv[1:])))

    seeds = [s for s in args.seeds.split(",") if s]
    if not seeds:
        ap.error(f"--seeds names no seed; known seeds: {', '.join(SEEDS)}")
    if args.every < 1 or (args.cases is not None and args.cases < 1) or args.jobs < 1:
        ap.error(f"--every, --cases and --jobs must be positive, got {args.every}, {args.cases}, {args.jobs}")
    try:
        config = TrajoptConfig(knots=args.knots, collocation=args.collocation, max_hops=args.max_hops,
                               solver=args.solver, lstm_weights=args.lstm_weights, starts=args.starts)
        options = label_options(args.options, seeds, kind="seed")
        for seed in seeds:
            check_seed(seed, options.get(seed), config)
    except ValueError as exc:
        ap.error(str(exc))
    try:
        suite = load_suite(args.suite)
    except (OSError, ValueError) as error:  # a missing or malformed suite file
        ap.error(str(error))
    cases = list(suite.cases[::args.every])[:args.cases]
    params = SlipParams(friction=suite.friction)

    def stamp(path):  # a retrained checkpoint at the same path must not reuse cached lstm cases
        st = Path(path).stat()
        return f"{st.st_size}:{st.st_mtime_ns}"

    weights_stamp = stamp(args.lstm_weights) if args.lstm_weights else ""
    code = source_digest()
    setup = json.dumps([asdict(config), weights_stamp, code, suite.goal_x, suite.friction], sort_keys=True,
                       default=str)
    seed_setup = {s: [options.get(s, {}), stamp(options[s]["weights"]) if "weights" in options.get(s, {}) else ""]
                  for s in seeds}
    key = lambda seed, case: hashlib.sha256(
        json.dumps([setup, seed, seed_setup[seed], case.id, case.terrain.to_dict(), list(case.apex)],
                   sort_keys=True).encode()).hexdigest()[:20]
    cache_path = Path(args.out + ".cases.jsonl")
    if args.no_resume and cache_path.exists():
        cache_path.unlink()
    cache = read_jsonl_cache(cache_path, lambda e: e["key"], lambda e: e["record"])

    from tqdm import tqdm

    problems = [make_problem(case.apex, perceived(case.terrain, case.apex.x), suite.goal_x, params) for case in cases]
    keys = {(s, i): key(s, case) for i, case in enumerate(cases) for s in seeds}
    records = {pair: cache[k] for pair, k in keys.items() if k in cache}
    # case-major: every seed sees the same cases at any point of a partial run
    todo = [(s, i) for i in range(len(cases)) for s in seeds if (s, i) not in records]
    tasks = [((s, i), (problems[i], s, config, cases[i].terrain, True, options.get(s)))  # True: verify on Drake
             for s, i in todo]
    bar = tqdm(total=len(cases) * len(seeds), initial=len(records), disable=args.quiet, unit="solve", desc=suite.name)
    with open_jsonl_cache(cache_path) as sink:
        for (s, i), result in results_of(optimize, tasks, args.jobs):
            records[(s, i)] = {"id": cases[i].id, **result}
            append_jsonl(sink, {"key": keys[(s, i)], "record": records[(s, i)]})
            bar.update(1)
            bar.set_postfix({n: sum(r["verified"] for (m, _), r in records.items() if m == n) for n in seeds})
    bar.close()
    done = {s: [records[(s, i)] for i in range(len(cases))] for s in seeds}
    results = {"format": FORMAT, "suite": suite.name, "suite_file": str(args.suite), "cases_n": len(cases),
               "every": args.every, "config": asdict(config), "options": options,
               "seeds": {s: summarize(done[s]) for s in seeds}}
    with atomic_write(args.out, "w") as f:
        json.dump(results, f, indent=1)
    print(table(results))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
