"""Figures and animations of simulated hops (kept apart from the dynamics; matplotlib only, no display).

Figures are built on Agg canvases directly, never through pyplot, so importing this module neither needs a
display nor changes the caller's matplotlib backend.
"""
from __future__ import annotations

import math

import numpy as np
from matplotlib.animation import PillowWriter
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from drakeslip.slip_hopper import HybridState, Mode
from drakeslip.simulation import SimulationResult
from drakeslip.terrain import Terrain

GROUND_COLOR = "#8c6d46"
BODY_COLOR = "#1f4e99"
LEG_COLOR = "#333333"
RETRACTED_FRACTION = 0.35  # a retracted leg is drawn this fraction of its rest length, straight down
_MODE = HybridState._fields.index("mode")
_DEPLOYED = HybridState._fields.index("leg_deployed")
_ANGLE = HybridState._fields.index("leg_angle")
_FOOT_X, _FOOT_Z = HybridState._fields.index("foot_x"), HybridState._fields.index("foot_z")


def new_axes(figsize=(12, 4.5)):
    """A fresh Axes on its own Agg figure (save it with ``ax.figure.savefig``)."""
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig.add_subplot()


def _floor_level(terrain: Terrain, xlim) -> float:
    """Bottom of the drawn ground: a little below the lowest solid (non-ditch) cell in view."""
    heights = terrain.height_at(np.arange(xlim[0], xlim[1] + terrain.cell, terrain.cell / 2))
    solid = heights[heights > terrain.ditch_height]
    return (float(solid.min()) if solid.size else 0.0) - 0.3


def plot_terrain(ax, terrain: Terrain, xlim) -> None:
    """Solid ground as filled columns down to the bottom of the view; ditches are left open (holes) with
    their walls drawn, going on below the view."""
    x_lo, x_hi = xlim
    floor = _floor_level(terrain, xlim)
    first, last = terrain.index(x_lo), terrain.index(x_hi)
    edges = terrain.x0 + terrain.cell * np.arange(first, last + 2)
    edges[0], edges[-1] = min(edges[0], x_lo), max(edges[-1], x_hi)  # the flat extension beyond the ends
    heights = terrain.heights[first:last + 1]
    ditch = heights <= terrain.ditch_height
    surface = np.where(ditch, floor - 1.0, heights)
    ax.fill_between(np.repeat(edges, 2)[1:-1], np.repeat(surface, 2), floor - 1.0, color=GROUND_COLOR, lw=0,
                    zorder=1)
    ax.stairs(surface, edges, baseline=None, color="black", lw=1.0, zorder=2)
    ax.set_xlim(x_lo, x_hi)
    ax.set_ylim(bottom=floor)


def _leg_end(body, hybrid_row, params, failure_foot=None):
    """Where to draw the foot: pinned in stance, at rest length along the leg angle when deployed in flight,
    short and straight down when retracted."""
    x, z = body
    mode = int(hybrid_row[_MODE])
    if mode == Mode.STANCE:
        return hybrid_row[_FOOT_X], hybrid_row[_FOOT_Z]
    if mode == Mode.FAILED and failure_foot is not None:
        return failure_foot
    if hybrid_row[_DEPLOYED]:
        angle = hybrid_row[_ANGLE]
        return x + params.leg_length * math.sin(angle), z - params.leg_length * math.cos(angle)
    return x, z - RETRACTED_FRACTION * params.leg_length


def _view(path: np.ndarray, margin: float = 0.6):
    return float(path[:, 0].min()) - margin, float(path[:, 0].max()) + margin


def _heights_in_view(terrain: Terrain, path: np.ndarray):
    """(bottom, top) of the view: below the lowest solid ground, above the body's highest point."""
    return _floor_level(terrain, _view(path)), float(path[:, 1].max()) + 0.25


def _figsize(x_span: float, z_span: float, width: float, extra_height: float):
    """A figure ``width`` inches wide whose height fits an equal-aspect view of x_span by z_span metres."""
    return width, min(width * z_span / x_span, 2 * width) + extra_height


def plot_hops(terrain: Terrain, path, legs, footholds, apexes, failure=None, ax=None, title: str = ""):
    """A hopper's run drawn to scale: the terrain under the body's ``path`` ((N, 2) x, z; the view spans all of
    it), the leg at every touchdown and liftoff (``legs``: (kind, hip (x, z), foot (x, z)), kind "touchdown" or
    "liftoff"), the executed ``footholds`` ((x, z) each), the ``apexes`` ((x, z) each, the start's first) and the
    ``failure`` ((x, z) of the body, (x, z) of the foot or None, its name) if any. Returns the Axes."""
    own_figure = ax is None
    path = np.asarray(path, dtype=float)
    xlim = _view(path)
    z_lo, z_hi = _heights_in_view(terrain, path)
    ax = new_axes(_figsize(xlim[1] - xlim[0], z_hi - z_lo, 12.0, 1.4)) if own_figure else ax
    plot_terrain(ax, terrain, xlim)
    ax.plot(path[:, 0], path[:, 1], color=BODY_COLOR, lw=1.5, label="body path", zorder=4)
    for kind, hip, foot in legs:
        style = "-" if kind == "touchdown" else "--"
        ax.plot([hip[0], foot[0]], [hip[1], foot[1]], style, color=LEG_COLOR, lw=1.2, zorder=3)
    if len(footholds):
        fx, fz = np.array(footholds).T
        ax.plot(fx, fz, "^", color="#d98c00", ms=8, mec="black", label="footholds", zorder=5)
    apexes = np.asarray(apexes, dtype=float).reshape(-1, 2)
    ax.plot(apexes[:, 0], apexes[:, 1], "o", color="white", mec=BODY_COLOR, ms=6, label="apexes", zorder=5)
    if failure is not None:
        (x, z), foot, name = failure
        if foot is not None:
            ax.plot([x, foot[0]], [z, foot[1]], ":", color="red", lw=1.5, zorder=3)
        ax.plot(x, z, "X", color="red", ms=12, mec="black", zorder=6, label=f"failure: {name}")
    ax.plot([], [], "-", color=LEG_COLOR, label="leg at touchdown")
    ax.plot([], [], "--", color=LEG_COLOR, label="leg at liftoff")
    ax.set_aspect("equal")
    ax.set_ylim(z_lo, z_hi)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("z [m]")
    ax.set_title(title)
    if own_figure:  # below the axes, where constrained layout keeps it clear of the labels
        ax.figure.legend(loc="outside lower center", fontsize=8, ncols=7, frameon=False)
    else:
        ax.legend(loc="best", fontsize=8)
    return ax


def plot_trajectory(result: SimulationResult, ax=None):
    """Terrain, body path, the leg at every touchdown and liftoff, footholds, apexes and the failure (if any).
    Returns the Axes."""
    legs = [(e.kind, e.state[:2], e.foot) for e in result.events
            if e.kind in ("touchdown", "liftoff") and e.foot is not None]
    footholds = [e.foot for e in result.events if e.kind == "touchdown"]
    apexes = [result.states[0, :2]] + [a[:2] for a in result.apexes]
    failure = None
    if result.failure_event is not None:
        e = result.failure_event
        failure = (e.state[:2], _leg_end(e.state[:2], result.hybrid[-1], result.params, e.foot), result.failure.name)
    outcome = f"failed ({result.failure.name})" if result.failure else "ok"
    return plot_hops(result.terrain, result.states[:, :2], legs, footholds, apexes, failure, ax,
                     f"SLIP hopper: {len(result.apexes)} apexes, {len(footholds)} footholds, {outcome}")


def animate(result: SimulationResult, path, fps: int = 30, view_width: float = 4.0, width: float = 8.0,
            dpi: int = 80) -> int:
    """Write a GIF of the body and leg in real time at ``fps`` frames per second, the view (``view_width``
    metres wide) following the body. Returns the number of frames."""
    if result.times.size == 0:
        raise ValueError("the result has no logged trajectory (simulate with log=True)")
    full = _view(result.states)
    view_width = min(view_width, full[1] - full[0])
    z_lo, z_hi = _heights_in_view(result.terrain, result.states)
    ax = new_axes(_figsize(view_width, z_hi - z_lo, width, 0.6))
    fig = ax.figure
    plot_terrain(ax, result.terrain, full)
    ax.set_aspect("equal")
    ax.set_ylim(z_lo, z_hi)
    trail, = ax.plot([], [], color=BODY_COLOR, lw=1, alpha=0.5, zorder=3)
    leg, = ax.plot([], [], color=LEG_COLOR, lw=2.5, solid_capstyle="round", zorder=4)
    body, = ax.plot([], [], "o", color=BODY_COLOR, ms=12, mec="black", zorder=5)
    label = ax.text(0.01, 0.95, "", transform=ax.transAxes, va="top", fontsize=9)
    failure_foot = result.failure_event.foot if result.failure_event is not None else None

    times = result.times
    frame_times = np.append(np.arange(times[0], times[-1], 1.0 / fps), times[-1])
    writer = PillowWriter(fps=fps)
    with writer.saving(fig, str(path), dpi):
        for t in frame_times:
            i = min(int(np.searchsorted(times, t, side="right")) - 1, times.size - 1)
            x, z = (np.interp(t, times, result.states[:, k]) for k in (0, 1))
            foot = _leg_end((x, z), result.hybrid[i], result.params, failure_foot)
            trail.set_data(result.states[:i + 1, 0], result.states[:i + 1, 1])
            leg.set_data([x, foot[0]], [z, foot[1]])
            body.set_data([x], [z])
            left = min(max(x - view_width / 2, full[0]), full[1] - view_width)
            ax.set_xlim(left, left + view_width)
            label.set_text(f"t = {t:5.2f} s   {Mode(int(result.hybrid[i, _MODE])).name.lower()}")
            writer.grab_frame()
    return frame_times.size


def plot_search_tree(ax, terrain: Terrain, parent, foothold, apex, best=(), xlim=None):
    """A footstep search tree over the terrain: each node i > 0 as the hop from its parent's apex down to its
    foothold and up to its own apex, coloured by depth (hops from the root); the nodes of ``best`` (a root-to-goal
    branch, root excluded) in bold. ``parent``, ``foothold`` and ``apex`` are per node, node 0 the root (its
    apex the start). Returns the depth colour bar's mappable."""
    from matplotlib.collections import LineCollection

    parent, foothold = np.asarray(parent), np.asarray(foothold, dtype=float)
    apex = np.asarray(apex, dtype=float).reshape(-1, 3)
    nodes = np.arange(1, parent.size)
    depth = np.zeros(parent.size, dtype=int)
    for i in nodes:  # parents come before their children
        depth[i] = depth[parent[i]] + 1
    ground = terrain.height_at(foothold[nodes])
    hops = np.stack([apex[parent[nodes], :2], np.column_stack([foothold[nodes], ground]), apex[nodes, :2]], axis=1)
    if xlim is None:
        xs = np.concatenate([apex[:, 0], foothold[nodes]])
        xlim = (float(xs.min()) - 0.5, float(xs.max()) + 0.5)
    plot_terrain(ax, terrain, xlim)
    lines = LineCollection(hops, array=depth[nodes], cmap="viridis", lw=0.6, alpha=0.55, zorder=3,
                           label="hops tried (apex to foothold to next apex, straight)")
    ax.add_collection(lines)
    ax.plot(foothold[nodes], ground, "|", color="black", ms=4, alpha=0.4, zorder=3,
            label=f"footholds tried ({nodes.size} nodes)")
    best = list(best)
    if best:
        chain = [0] + best
        path = [apex[0, :2]]
        for a, b in zip(chain[:-1], chain[1:]):
            path += [(foothold[b], terrain.height_at(foothold[b])), apex[b, :2]]
        path = np.array(path)
        ax.plot(path[:, 0], path[:, 1], "-", color="#d62728", lw=2.2, zorder=5, label="plan (best branch)")
        ax.plot(path[1::2, 0], path[1::2, 1], "^", color="#d98c00", mec="black", ms=7, zorder=6,
                label="planned footholds")
    ax.plot(apex[0, 0], apex[0, 1], "o", color="white", mec=BODY_COLOR, mew=2, ms=9, zorder=6, label="start apex")
    ax.set_xlim(*xlim)
    ax.set_ylim(top=float(apex[:, 1].max()) + 0.2)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("z [m]")
    return lines
