"""Statistics and tables of evaluation results: success rates with their 95 % intervals, work per planning call."""
from __future__ import annotations

import math
import statistics
from collections import Counter

Z95 = 1.959963984540054  # the 97.5 % quantile of the standard normal


def wilson_interval(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """The Wilson score interval for a binomial rate: unlike the normal approximation it stays inside [0, 1]
    and is not empty at 0 or n successes, the usual outcome for a good planner."""
    if n <= 0:
        raise ValueError(f"need at least one sample, got n={n}")
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return max(0.0, centre - half), min(1.0, centre + half)


def summarize(cases: list) -> dict:
    """The per-planner JSON block: success rate (fraction) and its 95 % Wilson interval, ODE calls, nodes expanded
    and planning time per planning call, the footholds per plan found, and how many calls the wall-clock safety
    limit stopped (their work depends on the machine); ``timing_mean_s``: the mean seconds per planning call in the
    step map, the controller, the footstep model and the search around them, over the calls that account for
    their time (``Plan.timing``; empty when none does)."""
    calls = [p for c in cases for p in c["plans"]]
    times = [p["t_plan_s"] for p in calls]
    lengths = [len(p["footholds"]) for p in calls if p["success"]]
    successes = sum(c["success"] for c in cases)
    return {"success_rate": successes / len(cases) if cases else 0.0,
            "success_interval": list(wilson_interval(successes, len(cases))) if cases else [0.0, 1.0],
            "ode_calls_mean": statistics.fmean(p["ode_calls"] for p in calls) if calls else 0.0,
            "ode_calls_median": statistics.median(p["ode_calls"] for p in calls) if calls else 0.0,
            "t_plan_mean_s": statistics.fmean(times) if times else 0.0,
            "t_plan_median_s": statistics.median(times) if times else 0.0,
            "nodes_expanded_mean": statistics.fmean(p["nodes_expanded"] for p in calls) if calls else 0.0,
            "footholds_mean": statistics.fmean(lengths) if lengths else 0.0,
            "time_limited_calls": sum(bool(p.get("time_limited")) for p in calls),
            "timing_mean_s": timing_means(calls),
            "cases": cases}


def timing_means(calls: list) -> dict:
    """Mean seconds per planning call in each part of ``Plan.timing``, over the calls that carry one."""
    timed = [p["timing"] for p in calls if p.get("timing")]
    return {part: statistics.fmean(t[part] for t in timed) for part in timed[0]} if timed else {}


def table(results: dict) -> str:
    """A text table like the paper's Tables II/III, with each success rate's 95 % interval."""
    w = max([12] + [len(name) for name in results["planners"]])
    rows = [f"Results on {results['suite']}",
            f"{'Planner':<{w}} {'Success %':>9} {'95% interval':>13} {'ODE calls':>10} {'ODE median':>10} "
            f"{'t_plan mean':>12} {'t_plan median':>14} {'nodes/plan':>10} {'steps/plan':>10} {'cases':>6}"]
    limited = []
    for name, r in results["planners"].items():
        lo, hi = r["success_interval"]
        rows.append(f"{name:<{w}} {100 * r['success_rate']:>9.1f} {f'{100 * lo:.1f}-{100 * hi:.1f}':>13} "
                    f"{r['ode_calls_mean']:>10.0f} {r['ode_calls_median']:>10.0f} "
                    f"{r['t_plan_mean_s']:>11.2g}s {r['t_plan_median_s']:>13.2g}s "
                    f"{r['nodes_expanded_mean']:>10.1f} {r['footholds_mean']:>10.1f} {len(r['cases']):>6}")
        if r.get("time_limited_calls"):
            limited.append(f"{name}: {r['time_limited_calls']}")
    if limited:
        rows.append("planning calls stopped by the wall-clock safety limit (machine-dependent): " + ", ".join(limited))
    return "\n".join(rows)


def outcomes(results: dict) -> str:
    """A line per planner under the table: the hops a case flew (mean; the footholds its plans executed, or the
    robot's "hops") and the failed cases by failure mode, most frequent first."""
    rows = []
    for name, r in results["planners"].items():
        hops = [c["hops"] if "hops" in c else sum(len(p.get("executed") or ()) for p in c["plans"])
                for c in r["cases"]]
        failed = Counter(c["failure"] or "unnamed" for c in r["cases"] if not c["success"])
        named = ", ".join(f"{mode} {n}" for mode, n in failed.most_common()) or "none"
        rows.append(f"{name}: {statistics.fmean(hops) if hops else 0.0:.1f} hops a case; failures: {named}")
    return "\n".join(rows)


def ratios(results: dict, baseline: str) -> str:
    """The baseline planner's ODE calls and planning time per planning call over each other planner's, from one
    run: means, medians, and the mean time over calls that found a plan (a search that finds none runs to its
    budget, which is the same for every planner and can dominate a mean over few cases)."""
    if baseline not in results["planners"]:
        raise ValueError(f"baseline {baseline!r} is not among the results' planners {list(results['planners'])}")

    def stats(r):
        calls = [p for c in r["cases"] for p in c["plans"]]
        found = [p["t_plan_s"] for p in calls if p["success"]]
        return (r["ode_calls_mean"], r["ode_calls_median"], r["t_plan_mean_s"],
                statistics.fmean(found) if found else math.nan, r["t_plan_median_s"])

    base = stats(results["planners"][baseline])
    w = max([12] + [len(name) for name in results["planners"]])
    heads = ("ODE mean", "ODE median", "t_plan mean", "t mean, found", "t_plan median")
    rows = [f"{baseline} / planner, per planning call", f"{'Planner':<{w}} " + " ".join(f"{h:>13}" for h in heads)]
    for name, r in results["planners"].items():
        if name != baseline:
            cells = (b / x if x != 0 else math.inf for b, x in zip(base, stats(r)))
            rows.append(f"{name:<{w}} " + " ".join(f"{c:>12.2f}x" for c in cells))
    return "\n".join(rows)
