"""Views of the spatial hopper: the figure (top view and side profile), the Meshcat replay as self-contained HTML,
the merged boxes it draws the height map with, the leg it draws, and what a real browser shows of the replay (the
hopper in view at several times while the camera follows it; a check that fails where the hopper is hidden)."""
import base64
import math
import re

import numpy as np
import pytest
from test_meshcat_replay import near, near_mask, require_browser, shots

from drakeslip.params import SlipParams
from drakeslip.spatial.families import height_map_family
from drakeslip.spatial.heightmap import HeightMap
from drakeslip.spatial.simulation import simulate3d

GOAL = (12.0, 1.2)


def raibert(speed: float = 1.5, side_speed: float = 0.15, gain: float = 0.06, stance: float = 0.15):
    """(pitch, roll) at each apex from Raibert's rule: the foot half a stance's travel ahead of the body, moved
    further along a speed above the wanted one (``speed`` along x, ``side_speed`` along y)."""
    def command(apex, _hop):
        dx = apex.xdot * stance / 2 + gain * (apex.xdot - speed)
        dy = apex.ydot * stance / 2 + gain * (apex.ydot - side_speed)
        roll = math.asin(dy / 0.5)
        return math.asin(dx / 0.5 / math.cos(roll)), roll
    return command


@pytest.fixture(scope="module")
def course_run():
    """Eleven hops over a course (stairs up and down, then blocks among holes) drifting to +y, the last foot in a
    hole (8.2 s); planned footholds a few centimetres off the executed ones."""
    run = simulate3d((0.0, 0.0, 0.9, 1.5, 0.0), raibert(), height_map_family("course")(5, 0.2), SlipParams(),
                     max_hops=14)
    assert run.failure is not None and run.failure.name == "FOOT_COLLISION" and len(run.footholds) >= 10
    planned = np.array(run.footholds)[:, :2] + (0.05, -0.03)
    return run, planned


def rasterized(rectangles, shape) -> np.ndarray:
    """The heights the rectangles (j0, j1, i0, i1, height) give a grid of ``shape`` (NaN where none), checking
    that none overlaps another."""
    grid, count = np.full(shape, np.nan), np.zeros(shape, dtype=int)
    for j0, j1, i0, i1, h in rectangles:
        grid[j0:j1, i0:i1] = h
        count[j0:j1, i0:i1] += 1
    assert count.max() <= 1, "rectangles overlap"
    return grid


@pytest.mark.parametrize("family", ["gaps", "stones", "stairs", "course"])
def test_merged_boxes_cover_exactly_the_solid_cells(family):
    from drakeslip.spatial.heightmap import merge_cells
    from drakeslip.spatial.meshcat_replay import height_map_boxes
    from drakeslip.spatial.viz import crop

    m = height_map_family(family)(1, 0.7)
    path = np.array([[0.0, 0.0], [9.0, 1.0]])
    j0, j1, i0, i1 = crop(m, path, 1.5)
    cells = m.heights[j0:j1, i0:i1]
    boxes = merge_cells(cells)
    np.testing.assert_array_equal(rasterized(boxes, cells.shape), cells)  # NaN (holes) where no box
    solid = int(np.isfinite(cells).sum())
    assert len(boxes) < solid / 10, (len(boxes), solid)
    world = height_map_boxes(m, path)
    assert len(world) == len(boxes)
    area = sum((x1 - x0) * (y1 - y0) for x0, x1, y0, y1, _ in world)
    assert area == pytest.approx(solid * m.cell ** 2)
    assert min(b[0] for b in world) >= -1.5 - m.cell and max(b[1] for b in world) <= 10.5 + m.cell
    for x0, x1, y0, y1, top in world[::7]:
        assert m.height_at((x0 + x1) / 2, (y0 + y1) / 2) == top


def test_merge_cells_on_a_small_grid():
    from drakeslip.spatial.heightmap import merge_cells

    nan = math.nan
    cells = np.array([[0.0, 0.0, nan, 0.1], [0.0, 0.0, nan, 0.1], [0.2, 0.0, 0.0, 0.0]])
    boxes = merge_cells(cells)
    assert boxes == [(0, 2, 0, 2, 0.0), (0, 2, 3, 4, 0.1), (2, 3, 0, 1, 0.2), (2, 3, 1, 4, 0.0)]
    assert merge_cells(np.full((2, 3), nan)) == []


def test_the_leg_is_drawn_at_its_length(course_run):
    from drakeslip.hybrid_hopper import Mode
    from drakeslip.meshcat_replay import RETRACTED_FRACTION
    from drakeslip.spatial.dynamics import leg_offset
    from drakeslip.spatial.meshcat_replay import leg_vector

    run, _ = course_run
    p, h, s = run.params, run.hybrid, run.states
    stance = np.flatnonzero(h[:, 0] == Mode.STANCE)
    lengths = [np.linalg.norm(leg_vector(s[i, :3], h[i], p)) for i in stance]
    assert min(lengths) < 0.9 * p.leg_length and max(lengths) <= p.leg_length + 1e-6  # compressing in stance
    i = np.flatnonzero((h[:, 0] == Mode.FLIGHT) & (h[:, 1] == 1))[0]
    assert leg_vector(s[i, :3], h[i], p) == pytest.approx(leg_offset(h[i, 2], h[i, 3], p.as_array()))
    assert abs(h[i, 3]) > 0.01   # a rolled leg: the sideways component is drawn
    i = np.flatnonzero((h[:, 0] == Mode.FLIGHT) & (h[:, 1] == 0))[0]
    assert leg_vector(s[i, :3], h[i], p) == (0.0, 0.0, -RETRACTED_FRACTION * p.leg_length)


def test_the_figure_shows_the_map_around_the_path_and_the_profile(course_run, tmp_path):
    from drakeslip.spatial.viz import plot_run3d, plot_simulation3d

    run, planned = course_run
    fig = plot_simulation3d(run, planned, GOAL, out=tmp_path / "view.png")
    assert (tmp_path / "view.png").stat().st_size > 20_000
    colorbars = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
    top, side = [ax for ax in fig.axes if ax not in colorbars]
    assert len(colorbars) == 1 and colorbars[0].get_ylabel() == "ground height [m]"
    assert (top.get_xlabel(), top.get_ylabel()) == ("x [m]", "y [m]") and side.get_ylabel() == "z [m]"
    (x_lo, x_hi), (y_lo, y_hi) = top.get_xlim(), top.get_ylim()
    path = run.states[:, :2]
    assert x_lo <= path[:, 0].min() and x_hi >= max(path[:, 0].max(), GOAL[0]) and y_lo <= path[:, 1].min()
    assert x_hi - x_lo < 16.0 and y_hi - y_lo < 4.0   # cropped: the map is 23 m x 6 m
    labels = top.get_legend_handles_labels()[1]
    assert {"executed footholds", "planned footholds", "goal", "failure: FOOT_COLLISION"} <= set(labels)
    flat = plot_run3d(HeightMap.flat(), [(0, 0, 0.9), (1, 0.1, 0.8)], [(0.5, 0.0, 0.0)], [(1.2, 0.1)])
    assert len(flat.axes) == 3


def commands(page_text: str) -> list[bytes]:
    """The Meshcat commands a static page embeds (msgpack, each base64 in a data: URL)."""
    return [base64.b64decode(b) for b in re.findall(r"data:application/octet-binary;base64,([A-Za-z0-9+/=]+)",
                                                    page_text)]


def test_the_replay_is_self_contained_html_with_the_animation(course_run, tmp_path):
    from pydrake.geometry import Meshcat

    from drakeslip.spatial.meshcat_replay import draw_replay3d, write_replay3d

    run, planned = course_run
    meshcat = Meshcat()
    frames = draw_replay3d(meshcat, run, planned, fps=20)
    assert frames == pytest.approx(run.times[-1] * 20, abs=2)
    for path in ("terrain/0", "terrain/floor", "hopper/body", "hopper/leg/rod", "hopper/leg/foot", "planned/3",
                 "executed/9", "failure/label", "path"):
        assert meshcat.HasPath(f"/drakeslip/world/{path}"), path
    with pytest.raises(ValueError, match="no logged trajectory"):
        draw_replay3d(meshcat, simulate3d((0, 0, 0.9, 1.5, 0), [(0.2, 0)], log=False))
    page = write_replay3d(run, tmp_path / "replay3d.html", planned, title="a course")
    text = page.read_text()
    assert not re.search(r"<script[^>]*\bsrc\s*=\s*[\"']?(https?:)?//", text), "the page loads a remote script"
    assert "<title>a course</title>" in text and "failed: FOOT_COLLISION at t = 8.2" in text
    assert "planned footholds" in text and 100_000 < page.stat().st_size < 6_000_000
    embedded = commands(text)
    animation = [c for c in embedded if b"set_animation" in c]
    assert len(animation) == 1 and b"/drakeslip/world/hopper/body" in animation[0]


@pytest.fixture(scope="module")
def replay_page(course_run, tmp_path_factory):
    from drakeslip.spatial.meshcat_replay import write_replay3d

    run, planned = course_run
    return write_replay3d(run, tmp_path_factory.mktemp("replay3d") / "replay3d.html", planned, fps=20)


def body_pixels(images) -> list:
    from drakeslip.meshcat_replay import BODY_RGB
    from drakeslip.replay_scene import HEADER_PX

    return [near_mask(image[HEADER_PX + 2:], BODY_RGB, 45) for image in images]


def test_the_hopper_stays_in_view_in_headless_chromium(replay_page):
    """The page shows the body at 0.5 s, 4 s and the end of the run (in the hole), at one place across the window
    while the ground moves under it (the camera follows); the executed and planned footholds are drawn."""
    require_browser()
    from drakeslip.replay_scene import EXECUTED_RGB, HEADER_PX, PLANNED_RGB

    images = shots(replay_page, [0.5, 4.0, 20.0], replay_page.parent)
    bodies = body_pixels(images)
    counts = [int(b.sum()) for b in bodies]
    assert min(counts) > 150, f"the body is not drawn in every screenshot: {counts} pixels of its colour"
    width = bodies[0].shape[1]
    columns = [float(np.nonzero(b)[1].mean()) for b in bodies]
    assert 0.3 * width < min(columns) and max(columns) < 0.7 * width, columns
    assert max(columns) - min(columns) < 0.05 * width, columns
    scenes = [image[HEADER_PX + 2:] for image in images]
    moved = [float((a != b).any(axis=-1).mean()) for a, b in zip(scenes, scenes[1:])]
    assert min(moved) > 0.05, f"the view did not change under the body: {moved}"
    assert all(near(scene, EXECUTED_RGB) > 20 for scene in scenes[1:])
    assert all(near(scene, PLANNED_RGB) > 20 for scene in scenes)


def test_the_body_check_fails_where_the_hopper_is_hidden(replay_page):
    require_browser()
    images = shots(replay_page, [4.0], replay_page.parent, hide="/drakeslip/world/hopper")
    assert int(body_pixels(images)[0].sum()) < 20
