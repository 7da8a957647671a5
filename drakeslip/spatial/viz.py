"""Figures of the spatial hopper's runs (the 3-D counterpart of ``drakeslip.viz``; matplotlib on Agg canvases, no
display, never through pyplot, as there).

``plot_run3d`` draws a run to read at a glance: on top the height map seen from above around the body's path
(coloured by height, holes dark), the path, the executed footholds (filled orange), the planned ones (hollow cyan),
the goal (a star) and the failure (a red X); below it the side profile, the body's height and the ground under its
path over the distance travelled along the path. ``plot_simulation3d`` draws a SimulationResult3D.

The colours are the 2-D views': the body's blue (``drakeslip.viz``), the ground's brown in the profile, and the
2-D replay's footholds, planned and executed (``drakeslip.replay_scene``). ``ground_colormap`` and ``height_norm``
colour heights for the 3-D replay (``drakeslip.spatial.meshcat_replay``) as for this figure.
"""
from __future__ import annotations

import math

import numpy as np
from matplotlib import colormaps
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import ListedColormap, Normalize
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from drakeslip.replay_scene import EXECUTED_RGB, FAILURE_RGB, PLANNED_RGB
from drakeslip.spatial.heightmap import HeightMap
from drakeslip.spatial.simulation import SimulationResult3D
from drakeslip.viz import BODY_COLOR, GROUND_COLOR

HOLE_COLOR = "#262626"
GOAL_COLOR = "#ffd21f"
TOP_MARGIN = 1.0       # [m] of the map shown around the path, the footholds and the goal in the top view
MIN_HEIGHT_SPAN = 0.1  # [m] the colour scale spans at least this much (a flat map gets one mid colour)


def ground_colormap() -> ListedColormap:
    """matplotlib's "terrain" map without its blue and cyan (water) end, which would read as the body's blue or
    the planned footholds' cyan: low ground green, then yellow, brown and grey; holes (masked cells) dark."""
    return ListedColormap(colormaps["terrain"](np.linspace(0.3, 0.9, 256)), name="ground").with_extremes(bad=HOLE_COLOR)


def height_norm(heights) -> Normalize:
    """The colour scale over the solid (non-NaN) ``heights``, at least MIN_HEIGHT_SPAN wide around them."""
    solid = np.asarray(heights, dtype=float)
    solid = solid[np.isfinite(solid)]
    lo, hi = (float(solid.min()), float(solid.max())) if solid.size else (0.0, 0.0)
    pad = max(MIN_HEIGHT_SPAN - (hi - lo), 0.0) / 2
    return Normalize(lo - pad, hi + pad)


def crop(height_map: HeightMap, points, margin: float) -> tuple:
    """(j0, j1, i0, i1): the rows j0..j1-1 and columns i0..i1-1 of ``height_map``'s cells within ``margin`` [m] of
    the bounding box of ``points`` ((N, >=2) x, y, ...; rows with NaN left out), at least one cell, clipped to the
    map."""
    xy = np.asarray(points, dtype=float).reshape(len(points), -1)[:, :2]
    xy = xy[np.isfinite(xy).all(axis=1)]
    (x_lo, y_lo), (x_hi, y_hi) = xy.min(axis=0) - margin, xy.max(axis=0) + margin
    ny, nx = height_map.shape
    x0, y0 = height_map.origin
    c = height_map.cell

    def span(lo, hi, origin, n):
        first = min(max(math.floor((lo - origin) / c), 0), n - 1)
        return first, min(max(math.ceil((hi - origin) / c), first + 1), n)

    return (*span(y_lo, y_hi, y0, ny), *span(x_lo, x_hi, x0, nx))


def foothold_points(footholds, height_map: HeightMap) -> np.ndarray:
    """(m, 3) x, y, z of ``footholds`` given as (x, y, z) or (x, y) (z: the map's height there, NaN over a
    hole)."""
    rows = np.asarray([] if footholds is None else footholds, dtype=float)
    rows = rows.reshape(len(rows), -1) if rows.size else np.zeros((0, 3))
    if rows.shape[1] == 2:
        rows = np.column_stack([rows, height_map.height_at(rows[:, 0], rows[:, 1])])
    return rows[:, :3]


def along_path(path: np.ndarray, xy) -> np.ndarray:
    """The distance along ``path`` ((N, >=2)) travelled in x-y to its point nearest each of ``xy`` ((k, 2))."""
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(path[:, :2], axis=0).T))])
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    nearest = np.argmin(np.linalg.norm(path[None, :, :2] - xy[:, None, :], axis=-1), axis=1) if len(xy) else []
    return s[nearest]


def plot_top(ax, height_map: HeightMap, cells: tuple, path: np.ndarray, executed, planned, goal, failure):
    """The top view (x right, y up, to scale) of the map's ``cells`` (``crop``'s (j0, j1, i0, i1)), the path and
    the markers. Returns the image."""
    j0, j1, i0, i1 = cells
    (x0, y0), c = height_map.origin, height_map.cell
    heights = height_map.heights[j0:j1, i0:i1]
    image = ax.imshow(np.ma.masked_invalid(heights), cmap=ground_colormap(), norm=height_norm(heights), origin="lower",
                      interpolation="nearest", extent=(x0 + i0 * c, x0 + i1 * c, y0 + j0 * c, y0 + j1 * c))
    ax.plot(path[:, 0], path[:, 1], color=BODY_COLOR, lw=1.8, label="body path", zorder=3)
    ax.plot(*path[0, :2], "o", color="white", mec=BODY_COLOR, mew=2, ms=8, label="start", zorder=4)
    ax.plot(executed[:, 0], executed[:, 1], "o", color=EXECUTED_RGB, mec="black", ms=7,
            label="executed footholds", zorder=5)
    if len(planned):
        ax.plot(planned[:, 0], planned[:, 1], "D", mfc="none", mec=PLANNED_RGB, mew=2, ms=9,
                label="planned footholds", zorder=6)
    if goal is not None:
        ax.plot(goal[0], goal[1], "*", color=GOAL_COLOR, mec="black", ms=18, label="goal", zorder=6)
    if failure is not None:
        body, foot, name = failure
        if foot is not None:
            ax.plot([body[0], foot[0]], [body[1], foot[1]], ":", color=FAILURE_RGB, lw=1.5, zorder=6)
        ax.plot(body[0], body[1], "X", color=FAILURE_RGB, mec="black", ms=13, label=f"failure: {name}", zorder=7)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    return image


def plot_profile(ax, height_map: HeightMap, path: np.ndarray, executed, planned, failure) -> None:
    """The side profile: the body's z and the ground under its path (holes as dark pits) over the distance along
    the path, the footholds at their nearest point of the path."""
    s = along_path(path, path[:, :2])
    along = np.arange(0.0, s[-1] + height_map.cell / 4, height_map.cell / 4)
    ground = height_map.height_at(np.interp(along, s, path[:, 0]), np.interp(along, s, path[:, 1]))
    ground = np.atleast_1d(np.asarray(ground, dtype=float))
    hole = np.isnan(ground)
    solid_z = np.concatenate([ground[~hole], executed[:, 2], planned[:, 2]])
    solid_z = solid_z[np.isfinite(solid_z)]
    bottom = (float(solid_z.min()) if solid_z.size else 0.0) - 0.3
    rim = np.interp(along, along[~hole], ground[~hole]) if (~hole).any() else np.full_like(along, bottom + 0.3)
    ax.fill_between(along, np.where(hole, bottom - 1.0, ground), bottom - 1.0, color=GROUND_COLOR, lw=0, zorder=1)
    ax.fill_between(along, rim, bottom - 1.0, where=hole, color=HOLE_COLOR, lw=0, zorder=1)
    ax.plot(s, path[:, 2], color=BODY_COLOR, lw=1.8, zorder=3)
    ax.plot(along_path(path, executed[:, :2]), executed[:, 2], "o", color=EXECUTED_RGB, mec="black", ms=7,
            zorder=5)
    if len(planned):
        ax.plot(along_path(path, planned[:, :2]), planned[:, 2], "D", mfc="none", mec=PLANNED_RGB, mew=2, ms=9,
                zorder=6)
    if failure is not None:
        body = failure[0]
        ax.plot(along_path(path, [body[:2]]), [body[2]], "X", color=FAILURE_RGB, mec="black", ms=13, zorder=7)
    ax.set_xlim(0.0, max(float(s[-1]), height_map.cell))
    ax.set_ylim(bottom, float(path[:, 2].max()) + 0.15)
    ax.set_xlabel("distance along the path (x-y) [m]")
    ax.set_ylabel("z [m]")
    ax.set_title("side profile: body height and the ground under its path", fontsize=10)


# many parameters: the run's parts and the figure's options, as ``drakeslip.viz.plot_hops`` takes them
def plot_run3d(height_map: HeightMap, path_xyz, executed_footholds, planned_footholds=None, failure=None,
               title: str = "", out=None, *, goal=None) -> Figure:
    """A spatial run at a glance: the top view of ``height_map`` around the body's path (``path_xyz`` (N, 3)) with
    the executed footholds ((k, 3)), the planned ones ((m, 2) x, y or (m, 3); None: none), the ``goal`` ((x, y)
    or None) and the ``failure`` ((x, y, z) of the body, (x, y, z) of the foot or None, its name) if any; below it
    the side profile along the path. Saved to ``out`` if given. Returns the Figure."""
    path = np.asarray(path_xyz, dtype=float).reshape(-1, 3)
    if len(path) == 0:
        raise ValueError("the run has no path to draw (path_xyz is empty)")
    executed = foothold_points(executed_footholds, height_map)
    planned = foothold_points(planned_footholds, height_map)
    goal = None if goal is None else tuple(float(g) for g in goal)
    goal_xy = np.zeros((0, 2)) if goal is None else np.array([goal[:2]])
    cells = crop(height_map, np.concatenate([path[:, :2], executed[:, :2], planned[:, :2], goal_xy]), TOP_MARGIN)
    j0, j1, i0, i1 = cells
    top_height = min(max(12.0 * (j1 - j0) / (i1 - i0), 1.8), 6.0)
    fig = Figure(figsize=(12.0, top_height + 3.4), layout="constrained")
    FigureCanvasAgg(fig)
    top, side = fig.subplots(2, 1, height_ratios=[top_height, 2.4])
    image = plot_top(top, height_map, cells, path, executed, planned, goal, failure)
    fig.colorbar(image, ax=top, label="ground height [m]", fraction=0.03, pad=0.01)
    top.set_title(title)
    plot_profile(side, height_map, path, executed, planned, failure)
    handles, labels = top.get_legend_handles_labels()
    if np.ma.is_masked(image.get_array()):  # the dark cells' entry, where the view has holes
        handles, labels = handles + [Patch(color=HOLE_COLOR)], labels + ["hole"]
    fig.legend(handles, labels, loc="outside lower center", fontsize=8, ncols=7, frameon=False)
    if out is not None:
        fig.savefig(out, dpi=110)
    return fig


def plot_simulation3d(result: SimulationResult3D, planned=None, goal=None, out=None) -> Figure:
    """``plot_run3d`` of a simulated run: its path, its touchdowns, its failure; ``planned`` footholds and the
    ``goal`` as there. Returns the Figure."""
    if result.times.size == 0:
        raise ValueError("the result has no logged trajectory (simulate3d with log=True)")
    failure = None
    if result.failure_event is not None:
        e = result.failure_event
        failure = (tuple(e.state[:3]), e.foot, result.failure.name)
    outcome = f"failed ({result.failure.name})" if result.failure else "ok"
    title = f"spatial SLIP hopper: {len(result.apexes)} apexes, {len(result.footholds)} footholds, {outcome}"
    return plot_run3d(result.height_map, result.states[:, :3], result.footholds, planned, failure, title, out,
                      goal=goal)
