"""Figures of results, written as PNG (matplotlib on Agg canvases, no display, the caller's backend untouched).

From results JSONs of ``verification.evaluation.evaluate`` (examples/evaluate.py, examples/plot_results.py):
``success_figure`` (success rate per planner and run with 95 % Wilson intervals, the paper's values marked),
``cost_figure`` (ODE calls and planning time per planning call, log scale) and ``noise_figure`` (success against
the noise scale of runs with ``realistic*K`` noise). From ``Robustness.to_dict()`` (examples/robustness.py):
``robustness_figure``. From a plan's Drake run (examples/verify_plan.py): ``plan_check_figure``. From trajectory
optimizations (examples/trajopt_warmstart.py): ``trajopt_figure``. Each names the planners, suite or terrain and
setting in its title, has units on its axes and a legend.
"""
from __future__ import annotations

import textwrap

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from drakeslip.noise import PROFILES, NoiseProfile, scale_of
from planners.registry import planner_name
from verification.report import wilson_interval

OUTCOME_COLORS = {"ok": "#9a9a9a", "SLIP": "#d62728", "TRIP": "#ff7f0e", "BOTTOM_OUT": "#9467bd",
                  "BODY_COLLISION": "#8c564b", "STALL": "#e377c2", "DITCH": "#1f77b4"}
RUN_MARKERS = "osD^vP*X"


def figure(size, rows: int = 1, cols: int = 1):
    """A Figure on its own Agg canvas and its axes, a (rows, cols) array."""
    fig = Figure(figsize=size, layout="constrained")
    FigureCanvasAgg(fig)
    return fig, fig.subplots(rows, cols, squeeze=False)


def save(fig, path, dpi: int = 120):
    from pathlib import Path

    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    return path


def noise_scale(noise: dict) -> float | None:
    """K when the noise profile ``noise`` (a NoiseProfile.to_dict()) is ``realistic*K``, else None."""
    return scale_of(NoiseProfile(**noise), PROFILES["realistic"])


def run_name(results: dict) -> str:
    """What tells one evaluation run from another in a legend: the suite, the noise, the backend, the period."""
    config = next(iter(results["planners"].values()))["config"]
    parts = [results["suite"]]
    if NoiseProfile(**config["noise"]).silent:
        parts.append("noiseless")
    else:
        k = noise_scale(config["noise"])
        parts.append(f"noise realistic x{k:g}" if k is not None else "noise (custom)")
    if config["backend"] != "drake":
        parts.append(f"{config['backend']} backend")
    return ", ".join(parts)


def _names(runs: list) -> list:
    names = [run_name(r) for r in runs]
    return [f"{n} (#{i + 1})" if names.count(n) > 1 else n for i, n in enumerate(names)]


def _labels(runs: list) -> list:
    return list(dict.fromkeys(label for r in runs for label in r["planners"]))


def success_figure(runs: list, path, paper: dict | None = None):
    """Success rate [%] of each planner in each run with its 95 % Wilson interval; ``paper`` (suite -> planner
    name -> (success %, ODE calls, t_plan)) marks the paper's value where the run's suite and the label's planner
    have one and the run is noiseless (the paper's protocol)."""
    labels, names = _labels(runs), _names(runs)
    fig, axes = figure((min(max(6.0, 1.3 * len(labels) + 3), 12.0), 5.0))
    ax = axes[0, 0]
    width = 0.75 / len(runs)
    marked = False
    for j, (r, name) in enumerate(zip(runs, names)):
        offset = (j - (len(runs) - 1) / 2) * width
        noiseless = NoiseProfile(**next(iter(r["planners"].values()))["config"]["noise"]).silent
        for i, label in enumerate(labels):
            block = r["planners"].get(label)
            if block is None:
                continue
            rate, (lo, hi) = 100 * block["success_rate"], (100 * v for v in block["success_interval"])
            first = label == next(iter(r["planners"]))  # one legend entry per run
            ax.errorbar(i + offset, rate, [[max(rate - lo, 0.0)], [max(hi - rate, 0.0)]], color=f"C{j}",
                        fmt=RUN_MARKERS[j % len(RUN_MARKERS)], ms=7, capsize=4,
                        label=f"{name} ({len(block['cases'])} cases)" if first else None)
            value = (paper or {}).get(r["suite"], {}).get(planner_name(label)) if noiseless else None
            if value is not None:
                ax.plot([i + offset - 0.45 * width, i + offset + 0.45 * width], [value[0]] * 2, "-", color="black",
                        lw=2.5, zorder=5, label=None if marked else "paper's value (Tables II/III)")
                marked = True
    ax.set_xticks(range(len(labels)), labels)
    ax.set_xlim(-0.5, len(labels) - 0.5)
    ax.set_ylim(-3, 103)
    ax.set_ylabel("success rate [%]  (bars: 95 % Wilson interval)")
    ax.set_xlabel("planner")
    ax.grid(axis="y", alpha=0.3)
    fig.legend(fontsize=8, loc="outside lower center", ncols=2, frameon=False)
    ax.set_title(wrapped(f"Success rate per planner ({', '.join(labels)}) on suite "
                         f"{', '.join(dict.fromkeys(r['suite'] for r in runs))}"), fontsize=10)
    return save(fig, path)


def cost_figure(runs: list, path):
    """Per planning call: ODE calls (step-map evaluations) and planning time [ms], one box per planner and run,
    log scales. A planner with no ODE calls at all is written as such instead of a box."""
    labels, names = _labels(runs), _names(runs)
    fig, axes = figure((min(max(7.0, 0.5 * len(labels) * len(runs) + 3), 12.0), 7.5), 2, 1)
    width = 0.7 / len(runs)
    for ax, key, scale, unit in ((axes[0, 0], "ode_calls", 1, "ODE calls per planning call"),
                                 (axes[1, 0], "t_plan_s", 1e3, "planning time per call [ms]")):
        for j, (r, name) in enumerate(zip(runs, names)):
            for i, label in enumerate(labels):
                if label not in r["planners"]:
                    continue
                values = np.array([p[key] for c in r["planners"][label]["cases"] for p in c["plans"]]) * scale
                x = i + (j - (len(runs) - 1) / 2) * width
                if values.size and not (values > 0).any():
                    ax.text(x, 0.5, "none", transform=ax.get_xaxis_transform(), ha="center", fontsize=8,
                            color=f"C{j}", rotation=90)
                    continue
                values = values[values > 0]
                box = ax.boxplot(values, positions=[x], widths=0.8 * width, patch_artist=True,
                                 flierprops={"ms": 3, "mec": f"C{j}"}, medianprops={"color": "black"})
                box["boxes"][0].set(facecolor=f"C{j}", alpha=0.6)
        ax.set_yscale("log")
        ax.set_ylabel(unit)
        ax.set_xticks(range(len(labels)), labels)
        ax.set_xlim(-0.6, len(labels) - 0.4)
        ax.grid(axis="y", which="major", alpha=0.3)
    for j, name in enumerate(names):
        n = sum(len(c["plans"]) for b in runs[j]["planners"].values() for c in b["cases"])
        axes[0, 0].plot([], [], "s", color=f"C{j}", alpha=0.6, ms=10, label=f"{name} ({n} planning calls)")
    fig.legend(fontsize=8, loc="outside lower center", ncols=2, frameon=False)
    axes[1, 0].set_xlabel("planner (boxes: quartiles; whiskers: 1.5 IQR; dots: beyond)")
    axes[0, 0].set_title(wrapped(f"Work per planning call: {', '.join(labels)} on suite "
                                 f"{', '.join(dict.fromkeys(r['suite'] for r in runs))}"), fontsize=10)
    return save(fig, path)


TIMING_PARTS = (("step_map_s", "step map"), ("controller_s", "controller"), ("model_s", "footstep model"),
                ("search_s", "search"))


def timing_figure(runs: list, path):
    """Where planning time goes: per planner and run, the mean time per planning call [ms] in the step map, the
    controller, the footstep model and the search around them (``Plan.timing``), stacked; planners whose calls
    carry no breakdown are left out. None when no run has one."""
    bars = [(f"{label}\n{name}", r["planners"][label]["timing_mean_s"]) for r, name in zip(runs, _names(runs))
            for label in _labels([r]) if r["planners"][label].get("timing_mean_s")]
    if not bars:
        return None
    fig, axes = figure((min(max(6.0, 1.0 * len(bars) + 3), 12.0), 4.5))
    ax = axes[0, 0]
    bottom = np.zeros(len(bars))
    for k, (part, name) in enumerate(TIMING_PARTS):
        values = np.array([1e3 * t.get(part, 0.0) for _, t in bars])
        ax.bar(range(len(bars)), values, bottom=bottom, color=f"C{k}", label=name)
        bottom += values
    ax.set_xticks(range(len(bars)), [b for b, _ in bars], fontsize=7)
    ax.set_ylabel("mean time per planning call [ms]")
    ax.grid(axis="y", alpha=0.3)
    fig.legend(fontsize=8, loc="outside lower center", ncols=4, frameon=False)
    ax.set_title(wrapped("Where planning time goes, per planning call (the compiled core's accounting)"), fontsize=10)
    return save(fig, path)


def noise_runs(runs: list) -> dict:
    """{(suite, planner label): sorted [(noise scale K, successes, cases)]} of the runs whose noise is
    realistic*K (runs with other noise are left out)."""
    out: dict = {}
    for r in runs:
        for label, block in r["planners"].items():
            k = noise_scale(block["config"]["noise"])
            if k is not None:
                cases = block["cases"]
                out.setdefault((r["suite"], label), []).append((k, sum(c["success"] for c in cases), len(cases)))
    return {key: sorted(points) for key, points in out.items()}


def wrapped(title: str, width: int = 100) -> str:
    """A title broken into lines of at most ``width`` characters (a long list of planners runs off the figure)."""
    return "\n".join(textwrap.wrap(title, width))


def noise_figure(runs: list, path):
    """Success rate [%] against the noise scale K of ``realistic*K`` (0 = noiseless), one line per planner
    label (and suite) run at two scales or more, with its 95 % Wilson band."""
    points = {key: rows for key, rows in noise_runs(runs).items() if len({k for k, _, _ in rows}) > 1}
    if not points:
        raise ValueError("no planner run at two or more noise scales realistic*K to plot against the scale")
    suites = list(dict.fromkeys(suite for suite, _ in points))
    fig, axes = figure((9.5, 4.8))
    ax = axes[0, 0]
    for i, ((suite, label), rows) in enumerate(points.items()):
        k, s, n = (np.array(v) for v in zip(*rows))
        band = np.array([wilson_interval(a, b) for a, b in zip(s, n)]) * 100
        ax.fill_between(k, band[:, 0], band[:, 1], color=f"C{i}", alpha=0.15, lw=0)
        cases = f"{int(n.min())}-{int(n.max())}" if n.min() != n.max() else f"{int(n[0])}"
        ax.plot(k, 100 * s / n, "o-", color=f"C{i}",
                label=f"{label}{' on ' + suite if len(suites) > 1 else ''} ({cases} cases per point)")
    realistic = PROFILES["realistic"]
    ax.set_xlabel(f"noise scale K of realistic*K  (K = 1: apex sd {1e3 * realistic.apex[0]:g} mm, "
                  f"{1e2 * realistic.apex[2]:g} cm/s; leg angle sd {realistic.leg_angle:g} rad; ...)", fontsize=9)
    ax.set_ylabel("success rate [%]  (band: 95 % Wilson)")
    ax.set_ylim(-3, 103)
    ax.grid(alpha=0.3)
    fig.legend(fontsize=8, loc="outside right center", frameon=False)
    ax.set_title(wrapped(f"Success against noise: {', '.join(dict.fromkeys(l for _, l in points))} on suite "
                         f"{', '.join(suites)}"), fontsize=10)
    return save(fig, path)


def robustness_figure(result: dict, path, title: str = ""):
    """The Monte Carlo draws of ``Robustness.to_dict()`` in (apex error, leg-angle error) space, coloured by
    outcome: per draw the largest (signed) error over the hops counted, apex x [mm] (left) and xdot [cm/s]
    (right) against leg angle [deg]; for a map plan's draws (apexes (x, y, z, xdot, ydot), angles (pitch, roll))
    the largest over x and y, over xdot and ydot, and over both angles."""
    draws = result["draws"]
    n = len(draws["outcome"])
    spatial = np.asarray(draws["apex_errors"][0]).shape[-1] == 5
    apex = np.array(draws["apex_errors"], dtype=float).reshape(n, -1, 5 if spatial else 3)
    angle = np.array(draws["angle_errors"], dtype=float).reshape(n, -1)
    outcome = np.array(draws["outcome"])
    position, speed = ((0, 1), (3, 4)) if spatial else ((0,), (2,))

    def worst(values):  # the signed value of largest magnitude along the hops (and the columns given)
        values = values.reshape(n, -1)
        return np.take_along_axis(values, np.abs(values).argmax(axis=1)[:, None], axis=1)[:, 0]

    th = np.degrees(worst(angle))
    fig, axes = figure((11.0, 4.6), 1, 2)
    for ax, values, unit in ((axes[0, 0], 1e3 * worst(apex[:, :, position]),
                              f"apex {'x or y' if spatial else 'x'} error told [mm]"),
                             (axes[0, 1], 1e2 * worst(apex[:, :, speed]),
                              f"apex {'xdot or ydot' if spatial else 'xdot'} error told [cm/s]")):
        for kind in sorted(set(outcome), key=lambda k: (k != "ok", k)):
            pick = outcome == kind
            ok = kind == "ok"
            ax.scatter(values[pick], th[pick], s=8 if ok else 22, alpha=0.45 if ok else 0.9,
                       c=OUTCOME_COLORS.get(kind, "black"), marker="o" if ok else "X", zorder=2 if ok else 3,
                       label=f"{'success' if ok else kind} ({pick.sum()})")
        ax.set_xlabel(unit + " (largest over the hops)")
        ax.set_ylabel("leg angle error [deg] (largest over the hops)")
        ax.axhline(0, color="black", lw=0.5)
        ax.axvline(0, color="black", lw=0.5)
        ax.grid(alpha=0.3)
    fig.legend(*axes[0, 0].get_legend_handles_labels(), fontsize=8, loc="outside lower center", ncols=7,
               title="outcome (draws)", title_fontsize=8, frameon=False)
    lo, hi = result["success_interval"]
    fig.suptitle(f"{title or result['planner'] + ' plan'}: {result['n']} noisy robots, first {result['hops']} hops on "
                 f"the {result['backend']} backend; success {100 * result['success_rate']:.1f} % "
                 f"(95 %: {100 * lo:.1f}-{100 * hi:.1f})", fontsize=10)
    return save(fig, path)


def plan_check_figure(check, record, sim, path, title: str = ""):
    """The Drake run ``sim`` of ``record`` (a PlanRecord) over the terrain, its planned footholds and predicted
    apexes against the actual ones, and the verdict ``check`` (Certificate or Counterexample): the first place
    the run left the plan is marked and named."""
    from drakeslip.viz import plot_trajectory

    ax = plot_trajectory(sim)
    terrain = record.terrain
    planned = np.asarray(record.footholds, dtype=float)
    ax.plot(planned, terrain.height_at(planned) + 0.05, "v", color="#2a7ab0", ms=7, mec="black", zorder=6,
            label="planned footholds")
    predicted = np.asarray(record.apexes, dtype=float).reshape(-1, 3)
    predicted = predicted[np.isfinite(predicted).all(axis=1)]
    if predicted.size:
        ax.plot(predicted[:, 0], predicted[:, 1], "+", color="#7b2fa8", ms=11, mew=2, zorder=6,
                label="predicted apexes")
    if check.ok:
        verdict = f"CERTIFIED (max foothold deviation {1e3 * check.deviation:.1f} mm)"
    else:
        x, z = check.state[0], check.state[1]
        ax.plot(x, z, "o", ms=22, mfc="none", mec="red", mew=2.5, zorder=7, label="counterexample")
        ax.annotate(check.reason(), (x, z), xytext=(0, 26), textcoords="offset points", ha="center",
                    fontsize=8, color="red", zorder=8, bbox={"fc": "white", "ec": "red", "alpha": 0.85})
        verdict = f"COUNTEREXAMPLE: {check.kind} at hop {check.hop}"
    ax.set_ylim(top=ax.get_ylim()[1] + 0.25)
    ax.set_title(f"{title or record.planner + ' plan'} on Drake ({check.mode}): {verdict}", fontsize=10)
    ax.figure.legends.clear()
    ax.figure.legend(loc="outside lower center", fontsize=8, ncols=5, frameon=False)
    return save(ax.figure, path)


def trajopt_figure(terrain, panels: list, path, title: str):
    """One panel per seed: the body paths on Drake of the seed's footholds (through the controller) and of the
    optimized leg angles (open loop), the optimizer's own footholds and apexes, over ``terrain``. ``panels``:
    dicts with "seed", "record" (an ``optimize`` record), "seed_sim" and "drake_sim" (SimulationResults or
    None)."""
    from drakeslip.viz import plot_terrain

    sims = [s for p in panels for s in (p["seed_sim"], p["drake_sim"]) if s is not None]
    xs = np.concatenate([s.states[:, 0] for s in sims] + [np.array(p["record"].get("footholds") or [0.0])
                                                          for p in panels])
    xlim = (float(xs.min()) - 0.4, float(xs.max()) + 0.4)
    top = max([float(s.states[:, 1].max()) for s in sims] + [0.0]) + 0.3
    fig, axes = figure((12.0, 2.6 * len(panels) + 0.8), len(panels), 1)
    for ax, p in zip(axes[:, 0], panels):
        plot_terrain(ax, terrain, xlim)
        r = p["record"]
        for sim, style, color, name in ((p["seed_sim"], "--", "#7f7f7f", "seed footholds, controller on Drake"),
                                        (p["drake_sim"], "-", "#1f4e99", "optimized angles, open loop on Drake")):
            if sim is not None:
                ok = "ok" if sim.failure is None else sim.failure.name
                ax.plot(sim.states[:, 0], sim.states[:, 1], style, color=color, lw=1.4, zorder=4,
                        label=f"{name} ({ok})")
        seed = np.asarray(r.get("seed_footholds") or [], dtype=float)
        ax.plot(seed, terrain.height_at(seed) + 0.03, "v", color="#bbbbbb", mec="black", ms=6, zorder=5,
                label="seed footholds")
        if r.get("footholds"):
            opt = np.asarray(r["footholds"], dtype=float)
            apexes = np.asarray(r["apexes"], dtype=float).reshape(-1, 3)
            ax.plot(opt, terrain.height_at(opt), "^", color="#d98c00", mec="black", ms=7, zorder=6,
                    label="optimized footholds")
            ax.plot(apexes[:, 0], apexes[:, 1], "o", mfc="white", mec="#d98c00", mew=1.5, ms=6, zorder=6,
                    label="optimized apexes")
        verdict = "verified" if r.get("verified") else ("converged" if r.get("converged") else "not converged")
        ax.set_title(f"seed {p['seed']}: {verdict}" + (f" ({r['error']})" if r.get("error") else ""), fontsize=9)
        ax.set_ylim(top=top)
        ax.set_aspect("equal")
        ax.set_ylabel("z [m]")
        ax.legend(fontsize=7, loc="upper left", ncols=3)
    axes[-1, 0].set_xlabel("x [m]")
    fig.suptitle(title, fontsize=10)
    return save(fig, path)

