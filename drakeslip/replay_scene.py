"""What the Meshcat replays of the SLIP (``drakeslip.meshcat_replay``) and of the multibody robot
(``drakeslip.multibody.replay``) draw alike: the camera, the lights, the terrain, the body's path, the planned and
executed footholds, the predicted apexes, the failure marker with its name, the animation that follows the body,
and the page around the scene (its header, legend and layout). Each replay draws its own hopper.

The scene is the x-z plane seen from -y by an orthographic camera (``Set2dRenderMode``), lit by ambient light
alone so each object shows its flat colour: terrain cells as boxes down to below the view (ditches left open, as
holes), the body's path (a thin line), planned footholds (cyan diamonds, slightly above the ground), executed
footholds (orange discs on the ground, shown from their touchdown on), predicted apexes (purple crosses) and the
failure (a red X over the body where it failed, with the failure's name above it in stroke letters: pydrake's
Meshcat has no text object, so the letters are a triangle mesh, which the static HTML shows like any other
geometry).

With ``follow`` the view tracks the body: the scene slides under a fixed camera, the body kept ``LEAD`` metres
right of the view's left edge and the view as tall as the whole run (the terrain below it, the body's highest
point above it), so the body stays in the frame for a run of any length; without it the whole run is framed at
once.
"""
from __future__ import annotations

import html
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from drakeslip.terrain import Terrain

# Flat colours (r, g, b in 0..1); ambient-only lighting renders them close to these values.
TERRAIN_RGB = (0.55, 0.43, 0.27)
PATH_RGB = (0.55, 0.68, 0.90)
PLANNED_RGB = (0.05, 0.70, 0.80)
EXECUTED_RGB = (0.95, 0.55, 0.0)
PREDICTED_RGB = (0.60, 0.20, 0.75)
FAILURE_RGB = (0.90, 0.05, 0.05)
HEADER_PX = 56             # the HTML header's height; the 3-D view fills the rest of the window
LEAD = 0.8                 # with follow: the body's distance from the view's left edge [m]
LABEL_HEIGHT = 0.1         # the failure's name [m]
# Layers along y (the camera looks along +y from y < 0): terrain at the back, footholds, the hopper (between
# Y_HOPPER - 0.06 and Y_HOPPER + 0.06), then the apex markers and the failure in front.
Y_TERRAIN, Y_FOOT, Y_HOPPER, Y_PATH, Y_MARK, Y_FAIL = 0.2, -0.02, -0.04, -0.08, -0.16, -0.20

# Stroke font on a 4 x 6 grid: each glyph is strokes separated by spaces, a stroke is a polyline of digit pairs xy.
_FONT = {
    "A": "0004264440 0343", "B": "00063645443303 3342413000", "C": "4536160501103041", "D": "00062644422000",
    "E": "46060040 0333", "F": "460600 0333", "G": "45361605011030414323", "H": "0006 4640 0343",
    "I": "1636 2620 1030", "J": "4641301001", "K": "0006 4602 1340", "L": "060040", "M": "0006234640",
    "N": "00064046", "O": "100105163645413010", "P": "00063645443303", "Q": "100105163645413010 2240",
    "R": "00063645443303 2340", "S": "453616050413334241301001", "T": "0646 2620", "U": "060110304146",
    "V": "062046", "W": "0610233046", "X": "0046 0640", "Y": "0623 4623 2320", "Z": "06464000",
    "0": "100105163645413010 0145", "1": "1526 2620 1030", "2": "05163645440040",
    "3": "0516364544334241301001 1333", "4": "30360242", "5": "4606033342413000", "6": "4536160501103041423303",
    "7": "064610", "8": "13040516364544331302011030414233", "9": "0110304145361605041343",
    "_": "0040", "-": "0343", ".": "2021", ":": "2122 2425", "=": "0242 0444", "/": "0046", " ": "",
}


@dataclass(frozen=True)
class Scene:
    """What a replay shows besides its hopper: the run's ``terrain``; the body's ``path`` ((N, 2) x, z) at
    ``times`` (N,); ``touchdowns`` ((K, 3) time, foot x, foot z: the executed footholds); ``planned`` ((n, 2)
    x, z) footholds and ``predicted`` ((m, 2) x, z) apexes; ``failure`` (time, x, z, name) or None;
    ``marker_size`` [m] of the foothold and apex markers; ``headroom`` [m] kept above the body's path (the
    hopper's parts above its body point)."""

    terrain: Terrain
    times: np.ndarray
    path: np.ndarray
    touchdowns: np.ndarray
    planned: np.ndarray
    predicted: np.ndarray
    failure: tuple | None
    marker_size: float
    headroom: float

    def x_at(self, t: float) -> float:
        return float(np.interp(t, self.times, self.path[:, 0]))


def rgba(rgb, alpha: float = 1.0):
    from pydrake.geometry import Rgba

    return Rgba(*rgb, alpha)


def pose(x: float, y: float, z: float, pitch: float = 0.0):
    """A pose in the x-z plane: translation (x, y, z), turned by ``pitch`` about +y."""
    from pydrake.math import RigidTransform, RotationMatrix

    return RigidTransform(RotationMatrix.MakeYRotation(pitch), [x, y, z])


def stroke_mesh(segments, width: float):
    """Vertices (3, N) and faces (3, M) of segments ((x0, z0), (x1, z1)) drawn ``width`` wide in the x-z plane:
    a quad per segment and an octagon at each end, so joints and ends are round."""
    seg = np.asarray(segments, dtype=float).reshape(-1, 2, 2)
    d = seg[:, 1] - seg[:, 0]
    d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)
    n = np.column_stack([-d[:, 1], d[:, 0]]) * width / 2
    quads = np.stack([seg[:, 0] + n, seg[:, 0] - n, seg[:, 1] - n, seg[:, 1] + n], axis=1).reshape(-1, 2)
    ends = np.unique(seg.reshape(-1, 2), axis=0)
    ring = np.exp(2j * np.pi * np.arange(8) / 8) * width / 2
    octagons = (ends[:, None, :] + np.stack([ring.real, ring.imag], axis=-1)[None]).reshape(-1, 2)
    corners = np.concatenate([quads, octagons])
    vertices = np.column_stack([corners[:, 0], np.zeros(len(corners)), corners[:, 1]]).T
    base = 4 * np.arange(len(seg))[:, None]
    fan = len(quads) + 8 * np.arange(len(ends))[:, None, None] + np.array([[0, k, k + 1] for k in range(1, 7)])
    faces = np.concatenate([base + [0, 1, 2], base + [0, 2, 3], fan.reshape(-1, 3)]).astype(np.int32).T
    return np.asfortranarray(vertices), np.asfortranarray(faces)


def text_segments(text: str, height: float):
    """Stroke segments of ``text`` (letters, digits, ``_ - . : = /``; others are left blank), left end of the
    baseline at the origin, capitals ``height`` tall. Returns (segments (K, 2, 2), width)."""
    unit, advance = height / 6.0, height * 5.5 / 6.0
    segments = []
    for i, char in enumerate(text.upper()):
        for stroke in _FONT.get(char, "").split():
            points = [(i * advance + int(stroke[k]) * unit, int(stroke[k + 1]) * unit)
                      for k in range(0, len(stroke), 2)]
            segments += list(zip(points[:-1], points[1:]))
    return np.array(segments).reshape(-1, 2, 2), max(len(text) * advance - height * 1.5 / 6.0, 0.0)


def solid_floor(terrain: Terrain, x_lo: float, x_hi: float) -> float:
    """The lowest solid (non-ditch) ground over [x_lo, x_hi] (0 where there is none)."""
    heights = terrain.height_at(np.arange(x_lo, x_hi + terrain.cell, terrain.cell / 2))
    solid = heights[heights > terrain.ditch_height]
    return float(solid.min()) if solid.size else 0.0


def terrain_boxes(terrain: Terrain, x_lo: float, x_hi: float, floor: float):
    """(left, right, top) of each run of equal-height solid cells over [x_lo, x_hi], the terrain extended flat
    beyond its ends; ditch cells (at or below ``terrain.ditch_height``) get no box. Boxes reach down to
    ``floor``."""
    first, last = int(terrain.index(x_lo)), int(terrain.index(x_hi))
    edges = terrain.x0 + terrain.cell * np.arange(first, last + 2)
    edges[0], edges[-1] = min(edges[0], x_lo), max(edges[-1], x_hi)
    heights = terrain.heights[first:last + 1]
    boxes, start = [], 0
    for i in range(1, heights.size + 1):
        if i == heights.size or heights[i] != heights[start]:
            if heights[start] > terrain.ditch_height and heights[start] > floor:
                boxes.append((float(edges[start]), float(edges[i]), float(heights[start])))
            start = i
    return boxes


def points(values, terrain: Terrain):
    """(x, z) rows from floats (x on the terrain: z its height there) or from tuples/ApexStates (their first two
    entries)."""
    rows = []
    for v in () if values is None else values:
        if np.ndim(v) == 0:
            rows.append((float(v), float(terrain.height_at(float(v)))))
        else:
            rows.append((float(v[0]), float(v[1])))
    return np.array(rows, dtype=float).reshape(-1, 2)


def framing(scene: Scene, follow: bool):
    """((left, right, bottom, top) of the camera's view, (lo, hi) x range of the terrain to draw, the bottom of
    the terrain boxes). Meshcat keeps the view's left edge and height and widens it to the window's aspect: the
    terrain is drawn far enough right for windows up to 5:1."""
    xs = np.concatenate([scene.path[:, 0], scene.planned[:, 0], scene.predicted[:, 0]])
    x_lo, x_hi = float(xs.min()), float(xs.max())
    floor = solid_floor(scene.terrain, x_lo - LEAD, x_hi + 1.0)
    z_lo = floor - 0.25
    z_hi = float(max(scene.path[:, 1].max(), scene.predicted[:, 1].max(initial=-np.inf))) + scene.headroom
    if scene.failure is not None:
        z_hi = max(z_hi, scene.failure[2] + 0.17 + LABEL_HEIGHT + 0.05)
    view_h = z_hi - z_lo
    if follow:
        view = (-LEAD, -LEAD + 16 / 9 * view_h, z_lo, z_hi)
        drawn = (x_lo - LEAD - 1.0, x_hi - LEAD + 5.0 * view_h)
    else:  # the whole run: at least as tall as the run's width at 16:9
        width = x_hi - x_lo + 1.0
        extra = max(width * 9 / 16 - view_h, 0.0)
        view = (x_lo - 0.5, x_lo - 0.5 + width, z_lo - extra / 2, z_hi + extra / 2)
        drawn = (x_lo - 1.0, x_lo - 0.5 + 5.0 * (view_h + extra))
    return view, drawn, floor - 2.0 * view_h


def draw_scene(meshcat, scene: Scene, root: str, follow: bool) -> dict:
    """Delete what is under ``root``, set the 2-D camera and ambient-only lights, and draw the terrain, the path
    and the markers under ``root``/world. Returns {path: time} of the markers shown from a time on (the executed
    footholds, the failure)."""
    from pydrake.geometry import Box, Sphere
    from pydrake.math import RigidTransform

    view, (draw_lo, draw_hi), bottom = framing(scene, follow)
    meshcat.Delete(root)
    meshcat.Set2dRenderMode(RigidTransform([0.0, -5.0, 0.0]), *view)
    for light in ("SpotLight", "PointLightNegativeX", "PointLightPositiveX", "FillLight"):
        meshcat.SetProperty(f"/Lights/{light}/<object>", "intensity", 0.0)
    meshcat.SetProperty("/Lights/AmbientLight/<object>", "intensity", math.pi)  # flat colours
    world = f"{root}/world"
    for i, (left, right, top) in enumerate(terrain_boxes(scene.terrain, draw_lo, draw_hi, bottom)):
        meshcat.SetObject(f"{world}/terrain/{i}", Box(right - left, 0.4, top - bottom), rgba(TERRAIN_RGB))
        meshcat.SetTransform(f"{world}/terrain/{i}", pose((left + right) / 2, Y_TERRAIN, (top + bottom) / 2))
    step = max(1, scene.times.size // 2000)
    path = scene.path[::step]
    line = np.column_stack([path[:, 0], np.full(len(path), Y_PATH), path[:, 1]])
    meshcat.SetLine(f"{world}/path", np.asfortranarray(line.T), 2.0, rgba(PATH_RGB))
    size = scene.marker_size
    for i, (x, z) in enumerate(scene.planned):
        meshcat.SetObject(f"{world}/planned/{i}", Box(size, 0.01, size), rgba(PLANNED_RGB))
        meshcat.SetTransform(f"{world}/planned/{i}", pose(x, Y_FOOT, z + 0.9 * size, math.pi / 4))
    cross = np.array([[(-1, 0), (1, 0)], [(0, -1), (0, 1)]]) * size
    for i, (x, z) in enumerate(scene.predicted):
        meshcat.SetTriangleMesh(f"{world}/predicted/{i}", *stroke_mesh(cross + (x, z), size / 3), rgba(PREDICTED_RGB))
        meshcat.SetTransform(f"{world}/predicted/{i}", pose(0.0, Y_MARK, 0.0))
    shown_from = {}
    for i, (t, x, z) in enumerate(scene.touchdowns):
        meshcat.SetObject(f"{world}/executed/{i}", Sphere(0.6 * size), rgba(EXECUTED_RGB))
        meshcat.SetTransform(f"{world}/executed/{i}", pose(x, Y_FOOT + 0.02, z))
        shown_from[f"{world}/executed/{i}"] = float(t)
    if scene.failure is not None:
        t, x, z, name = scene.failure
        bars = np.array([[(-1, -1), (1, 1)], [(-1, 1), (1, -1)]]) * 0.09 + (x, z)
        meshcat.SetTriangleMesh(f"{world}/failure/x", *stroke_mesh(bars, 0.025), rgba(FAILURE_RGB))
        letters, width = text_segments(name, LABEL_HEIGHT)
        origin = (x - min(width / 2, 0.3), z + 0.17)
        meshcat.SetTriangleMesh(f"{world}/failure/label", *stroke_mesh(letters + origin, 0.016), rgba(FAILURE_RGB))
        meshcat.SetTransform(f"{world}/failure", pose(0.0, Y_FAIL, 0.0))
        shown_from[f"{world}/failure"] = float(t)
    return shown_from


def animate(meshcat, scene: Scene, hopper_at, shown_from: dict, root: str, *, fps: float, speed: float,
            follow: bool) -> int:
    """Set (replacing any) the Meshcat animation of the run at ``speed`` times real time, ``fps`` frames a
    second, played once and held on its last frame: each frame the hopper as ``hopper_at(t)`` returns it
    ({path: RigidTransform}, [(path, property, value)]), the world slid under the camera by the body's x with
    ``follow``, each marker of ``shown_from`` visible from its time on. Frame 0 is also set as the scene's
    state. Returns the number of frames."""
    from pydrake.math import RigidTransform

    def frame_at(t):
        poses, props = hopper_at(t)
        if follow:
            poses[f"{root}/world"] = RigidTransform([-scene.x_at(t), 0.0, 0.0])
        return poses, props

    return play(meshcat, float(scene.times[0]), float(scene.times[-1]), frame_at, shown_from, fps=fps, speed=speed)


def play(meshcat, t0: float, t_end: float, frame_at, shown_from: dict, *, fps: float, speed: float) -> int:
    """Set (replacing any) the Meshcat animation from ``t0`` to ``t_end`` [s] at ``speed`` times real time, ``fps``
    frames a second, played once and held on its last frame: each frame the poses and properties ``frame_at(t)``
    returns ({path: RigidTransform}, [(path, property, value)]), each marker of ``shown_from`` visible from its time
    on. Frame 0 is also set as the scene's state. Returns the number of frames."""
    from pydrake.geometry import MeshcatAnimation

    if not (fps > 0 and speed > 0 and math.isfinite(fps) and math.isfinite(speed)):
        raise ValueError(f"fps and speed must be positive, got fps={fps}, speed={speed}")
    animation = MeshcatAnimation(fps)
    animation.set_loop_mode(MeshcatAnimation.LoopMode.kLoopOnce)
    animation.set_clamp_when_finished(True)
    n_frames = int(math.floor((t_end - t0) / speed * fps)) + 2  # the last frame shows the end of the run
    for k in range(n_frames):
        t = min(t0 + k * speed / fps, t_end)
        poses, props = frame_at(t)
        props = props + [(p, "visible", t >= t_shown) for p, t_shown in shown_from.items()]
        for p, value in poses.items():
            animation.SetTransform(k, p, value)
            if k == 0:
                meshcat.SetTransform(p, value)
        for p, name, value in props:
            animation.SetProperty(k, p, name, value)
            if k == 0:
                meshcat.SetProperty(p, name, value)
    meshcat.SetAnimation(animation)
    return n_frames


def swatch(rgb, text: str) -> str:
    """A legend entry: a square of colour ``rgb`` and ``text``."""
    colour = "#" + "".join(f"{round(255 * c):02x}" for c in rgb)
    return (f'<span style="display:inline-block;width:10px;height:10px;background:{colour};'
            f'margin:0 3px 0 10px"></span>{html.escape(text)}')


def legend(scene: Scene, hopper_items) -> list:
    """The legend's entries: the terrain, the hopper's parts (``hopper_items``: (rgb, name) pairs), and the markers
    the scene has."""
    items = [(TERRAIN_RGB, "terrain"), *hopper_items, (PATH_RGB, "body path"), (EXECUTED_RGB, "executed footholds")]
    if len(scene.planned):
        items.append((PLANNED_RGB, "planned footholds"))
    if len(scene.predicted):
        items.append((PREDICTED_RGB, "predicted apexes"))
    if scene.failure is not None:
        items.append((FAILURE_RGB, "failure"))
    return [swatch(rgb, text) for rgb, text in items]


def write_page(meshcat, path, title: str, summary: str, items, *, speed: float, fps: float) -> Path:
    """Write ``meshcat``'s scene as self-contained HTML (``Meshcat.StaticHtml``: three.js and the scene embedded,
    no server) to ``path`` under a header: ``title``, the run's ``summary``, the pace, and the legend (``items``,
    from ``legend``). The view fills the window below the header, which never scrolls. Returns the Path."""
    pace = "real time" if speed == 1 else f"{speed:g} x real time"
    line1 = (f"<b>{html.escape(title)}</b> &nbsp; {html.escape(summary)} &nbsp; "
             f"<i>{pace}, {fps:g} fps; Open Controls &gt; Animations to replay</i>")
    header = (f'<div id="drakeslip-header" style="height:{HEADER_PX}px;box-sizing:border-box;padding:6px 10px;'
              f'font:13px/20px sans-serif;white-space:nowrap;overflow:hidden;background:#f4f4f4;'
              f'border-bottom:1px solid #bbb">{line1}<br>{"".join(items)}</div>')
    page = meshcat.StaticHtml()
    page = page.replace("<title>Drake MeshCat</title>", f"<title>{html.escape(title)}</title>", 1)
    page = page.replace('<div id="meshcat-pane">', header + '\n  <div id="meshcat-pane">', 1)
    head, tail, end = page.rpartition("</body>")
    # Meshcat's controls (a dat.GUI panel the viewer puts at the top right) go below the header, over the view
    style = (f"<style>html, body {{ overflow: hidden; }} body > .dg.main {{ top: {HEADER_PX}px !important; }} "
             f"#meshcat-pane {{ height: calc(100vh - {HEADER_PX}px) !important; }}</style>\n")
    page = head + style + tail + end if tail else page
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(page)
    return path
