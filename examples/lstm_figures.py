"""The paper's Fig. 1 and Fig. 3, drawn with the paper's model: the LSTM's per-step probability over the terrain.

    python3 examples/lstm_figures.py --out docs

fig1_lstm_steps.png: one start on a mixed terrain; the distributions of the first and fourth steps drawn
over the terrain, with the hops the controller makes to the LSTM planner's first four footholds (on Drake).
fig3_second_step.png: ditch (top) and step (bottom) terrain, three initial energies each (arrow length ~
apex speed); the second step's distribution scaled so its mode has height 1, and the 4-step plan (modes).
The planner is the paper's LSTM planner (planners.make("lstm@paper")), with --model for another model.

Exit status: 0 when both figures were written, 2 for a usage or input error (e.g. a damaged model file),
3 a simulation crashed (one line naming what failed: drakeslip/jobs/cli.py).
"""
from __future__ import annotations

import sys

from drakeslip.jobs import cli  # before numpy: a Ctrl-C while it loads is one line (drakeslip/jobs/cli.py)
from drakeslip import cli_physics

import numpy as np

from drakeslip import ApexState, SlipParams, TERRAIN_FAMILIES
from planners.checkpoints import PAPER_WEIGHTS

FIGURES = ("fig1_lstm_steps.png", "fig3_second_step.png")
COLORS = ("#2ca02c", "#ff7f0e")  # first step, fourth step (the paper's green and orange)


def draw_distribution(ax, x, p, terrain, color, scale=0.35, label=None):
    """Probabilities drawn as a band standing on the terrain surface, the mode ``scale`` metres tall."""
    ground = terrain.height_at(x)
    solid = ground > terrain.ditch_height
    top = np.where(solid, ground, np.nan) + scale * p / p.max()
    ax.fill_between(x, np.where(solid, ground, np.nan), top, color=color, alpha=0.55, lw=0, zorder=3, label=label)


def fig1(planner, controller, args):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from drakeslip.simulation import simulate
    from drakeslip.viz import plot_terrain

    terrain = TERRAIN_FAMILIES["mixed"](args.seed)
    params = SlipParams()
    apex = ApexState(0.0, terrain.height_at(0.0) + 0.9, 1.8)
    probs, x = planner.distributions(apex, terrain, 4)
    modes = planner.plan(apex, terrain, 10.0, params).footholds[:4]  # the planner's decoding of the modes
    sim = simulate(apex, lambda a, hop: controller.leg_angle(a, modes[hop], terrain), terrain, params,
                   max_hops=len(modes))
    fig = Figure(figsize=(11, 3.6), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    plot_terrain(ax, terrain, (-1.0, 7.0))
    body = sim.states
    ax.plot(body[:, 0], body[:, 1], color="#1f4e99", lw=1.5, label="body (Drake, controller to those footholds)")
    for k, color in zip((0, 3), COLORS):
        draw_distribution(ax, x, probs[k], terrain, color, label=f"step {k + 1} distribution")
    ax.plot(modes, terrain.height_at(modes), "v", color="black", ms=7, label="the LSTM planner's footholds")
    outcome = (f"all {len(modes)} hops succeed" if sim.failure is None
               else f"hop {len(sim.footholds)} fails: {sim.failure.name}")
    ax.set_title(f"LSTM footstep distributions, mixed terrain seed {args.seed}, apex 0.9 m at 1.8 m/s: {outcome}")
    ax.set_aspect("equal")
    ax.set_ylim(top=1.6)
    ax.legend(loc="upper right", fontsize=8, ncols=2)
    fig.savefig(args.out / FIGURES[0], dpi=110)


def fig3(planner, args):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from drakeslip.viz import plot_terrain

    starts = [(0.8, 1.0), (0.9, 2.0), (1.0, 3.0)]  # (apex height above ground, speed): increasing energy
    fig = Figure(figsize=(14, 5.5), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(2, len(starts), sharey="row")
    for row, family in enumerate(("ditch", "step")):
        terrain = TERRAIN_FAMILIES[family](args.seed)
        for col, (h, v) in enumerate(starts):
            ax = axes[row, col]
            apex = ApexState(0.0, terrain.height_at(0.0) + h, v)
            probs, x = planner.distributions(apex, terrain, 4)
            plot_terrain(ax, terrain, (-0.5, 5.0))
            draw_distribution(ax, x, probs[1], terrain, COLORS[1], scale=0.6)
            modes = x[probs.argmax(axis=1)]
            ax.plot(modes, terrain.height_at(modes), "v", color="black", ms=6)
            ax.annotate("", xy=(apex.x + 0.35 * v, apex.z), xytext=(apex.x, apex.z),
                        arrowprops={"arrowstyle": "->", "color": "#1f4e99", "lw": 2})
            ax.plot(apex.x, apex.z, "o", color="#1f4e99")
            ax.set_title(f"{family}: apex {h} m, {v} m/s", fontsize=9)
            ax.set_ylim(top=terrain.height_at(0.0) + 1.3)
    fig.suptitle("Second-step distribution (scaled so every mode has the same height) and the 4-step LSTM plan "
                 "(triangles)")
    fig.savefig(args.out / FIGURES[1], dpi=110)


@cli_physics.reports_crashes
def main(argv=None) -> int:
    ap = cli.ArgumentParser(__doc__)
    ap.add_argument("--out", type=cli.output_folder, default="docs", help="folder the two figures are written to")
    ap.add_argument("--seed", type=cli.non_negative_int, default=3, help="seed of the mixed, ditch and step terrains")
    ap.add_argument("--model", type=cli.input_file, default=PAPER_WEIGHTS,
                    help="footstep model checkpoint the paper's planner runs with (the paper's model by default)")
    args = ap.parse_args(argv)

    from drakeslip.controller import StepLengthController
    from planners import make

    try:
        planner = make("lstm@paper", model=args.model)
    except (OSError, ValueError) as error:  # a damaged or mismatched model file
        ap.error(f"--model: {error}")
    controller = StepLengthController.load_default()
    try:
        args.out.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        ap.error(f"--out: cannot make the folder {str(args.out)!r}: {error.strerror}")
    fig1(planner, controller, args)
    fig3(planner, args)
    print(f"wrote {args.out / FIGURES[0]} and {args.out / FIGURES[1]}")
    return cli.OK


if __name__ == "__main__":
    sys.exit(main())
