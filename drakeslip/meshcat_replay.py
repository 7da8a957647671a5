"""Replays of simulated hops in Drake's Meshcat, saved as self-contained HTML (kept apart from the dynamics).

``draw_replay`` draws a SimulationResult into a given ``pydrake.geometry.Meshcat`` and sets an animation of it;
``write_replay`` does that in a fresh Meshcat and writes ``Meshcat.StaticHtml()`` (three.js and the scene embedded:
it opens offline, no server) with a header naming the run and the markers.

The scene is the x-z plane seen from -y by an orthographic camera (``Set2dRenderMode``), lit by ambient light
alone so each object shows its flat colour: terrain cells as boxes down to below the view (ditches left open, as
holes), the body (a sphere), the leg (a zigzag spring from hip to foot, drawn at its actual length: compressing in
stance, at rest length when deployed in flight, short and straight down when retracted), the body's path (a
thin line), planned footholds (cyan diamonds, slightly above the ground), executed footholds (orange discs on the
ground, shown from their touchdown on), the plan's predicted apexes (purple crosses) and the failure (a red X over
the body where it failed, with the failure's name above it in stroke letters: pydrake's Meshcat has no text
object, so the letters are a triangle mesh, which the static HTML shows like any other geometry).

The animation plays once at ``speed`` times real time (1 = real time) with frames at ``fps`` sampled from the
logged states (body interpolated between samples, the hybrid state of the latest sample), and stops on its last
frame; Meshcat's "Open Controls" menu replays it. With ``follow`` the view tracks the body (the scene slides under
a fixed camera, the body kept ``LEAD`` metres right of the left edge, the terrain ahead in view); without it the
whole run is framed at once.
"""
from __future__ import annotations

import html
import math
from pathlib import Path

import numpy as np

from drakeslip.hopper import HybridState, Mode
from drakeslip.simulation import SimulationResult
from drakeslip.terrain import Terrain

# Flat colours (r, g, b in 0..1); ambient-only lighting renders them close to these values.
TERRAIN_RGB = (0.55, 0.43, 0.27)
BODY_RGB = (0.12, 0.31, 0.60)
LEG_RGB = (0.15, 0.15, 0.15)
PATH_RGB = (0.55, 0.68, 0.90)
PLANNED_RGB = (0.05, 0.70, 0.80)
EXECUTED_RGB = (0.95, 0.55, 0.0)
PREDICTED_RGB = (0.60, 0.20, 0.75)
FAILURE_RGB = (0.90, 0.05, 0.05)
HEADER_PX = 56             # the HTML header's height; the 3-D view fills the rest of the window
LEAD = 0.8                 # with follow: the body's distance from the view's left edge [m]
RETRACTED_FRACTION = 0.35  # a retracted leg is drawn this fraction of its rest length, straight down (as viz)
# Layers along y (the camera looks along +y from y < 0): terrain at the back, footholds, the hopper, then the
# apex markers and the failure in front.
_Y_TERRAIN, _Y_FOOT, _Y_LEG, _Y_BODY, _Y_MARK, _Y_FAIL = 0.2, -0.02, -0.04, -0.06, -0.16, -0.20
_MODE, _DEPLOYED, _ANGLE = (HybridState._fields.index(f) for f in ("mode", "leg_deployed", "leg_angle"))
_FOOT_X, _FOOT_Z = HybridState._fields.index("foot_x"), HybridState._fields.index("foot_z")

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


def _rgba(rgb, alpha: float = 1.0):
    from pydrake.geometry import Rgba

    return Rgba(*rgb, alpha)


def _pose(x: float, y: float, z: float, pitch: float = 0.0):
    """A pose in the x-z plane: translation (x, y, z), turned by ``pitch`` about +y."""
    from pydrake.math import RigidTransform, RotationMatrix

    return RigidTransform(RotationMatrix.MakeYRotation(pitch), [x, y, z])


def _stroke_mesh(segments, width: float):
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


def _spring_segments(coils: int = 7, amplitude: float = 0.022):
    """A zigzag of unit length from the hip (z = 0) down to the foot (z = -1), straight for its first and last
    tenth; the leg node scales it along z to the leg's length."""
    z = np.concatenate([[0.0], np.linspace(-0.1, -0.9, 2 * coils + 1), [-1.0]])
    x = np.zeros_like(z)
    x[2:-2:2], x[3:-2:2] = amplitude, -amplitude
    points = np.column_stack([x, z])
    return np.stack([points[:-1], points[1:]], axis=1)


def leg_geometry(x: float, z: float, hybrid_row, params, failure_foot=None):
    """(angle from vertical, length) of the leg drawn from the body at (x, z): to the pinned foot in stance (and
    at a failure that has one), at rest length along the commanded angle when deployed in flight, else
    retracted."""
    mode = int(hybrid_row[_MODE])
    foot = (hybrid_row[_FOOT_X], hybrid_row[_FOOT_Z]) if mode == Mode.STANCE else None
    if mode == Mode.FAILED and failure_foot is not None:
        foot = failure_foot
    if foot is not None:
        dx, dz = foot[0] - x, z - foot[1]
        return math.atan2(dx, dz), math.hypot(dx, dz)
    if hybrid_row[_DEPLOYED]:
        return float(hybrid_row[_ANGLE]), params.leg_length
    return 0.0, RETRACTED_FRACTION * params.leg_length


def _solid_floor(terrain: Terrain, x_lo: float, x_hi: float) -> float:
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


def _points(values, terrain: Terrain, default_z):
    """(x, z) rows from floats (z from ``default_z(x)``) or from tuples/ApexStates (their first two entries)."""
    rows = []
    for v in () if values is None else values:
        if np.ndim(v) == 0:
            rows.append((float(v), float(default_z(float(v)))))
        else:
            rows.append((float(v[0]), float(v[1])))
    return np.array(rows, dtype=float).reshape(-1, 2)


def draw_replay(meshcat, sim: SimulationResult, planned_footholds=None, predicted_apexes=None, *, fps: float = 30.0,
                speed: float = 1.0, follow: bool = True, prefix: str = "/drakeslip") -> int:
    """Draw ``sim`` into ``meshcat`` under ``prefix`` (deleting what was there), set the 2-D camera and ambient-only
    lights, and set (replacing any) the Meshcat animation of the run: ``speed`` times real time, ``fps`` frames
    per second. ``planned_footholds`` are x
    positions (on the terrain) or (x, z) pairs; ``predicted_apexes`` are ApexStates or (x, z, ...) tuples.
    Returns the number of animation frames."""
    from pydrake.geometry import Box, MeshcatAnimation, Sphere
    from pydrake.math import RigidTransform

    if sim.times.size == 0:
        raise ValueError("the result has no logged trajectory (simulate with log=True)")
    if not (fps > 0 and speed > 0 and math.isfinite(fps) and math.isfinite(speed)):
        raise ValueError(f"fps and speed must be positive, got fps={fps}, speed={speed}")
    terrain, params, times, states = sim.terrain, sim.params, sim.times, sim.states
    planned = _points(planned_footholds, terrain, terrain.height_at)
    predicted = _points(predicted_apexes, terrain, terrain.height_at)
    failure = sim.failure_event
    xs = np.concatenate([states[:, 0], planned[:, 0], predicted[:, 0]])
    x_lo, x_hi = float(xs.min()), float(xs.max())
    floor = _solid_floor(terrain, x_lo - LEAD, x_hi + 1.0)
    z_lo = floor - 0.25
    label_height = 0.1
    z_hi = float(max(states[:, 1].max(), predicted[:, 1].max(initial=-np.inf))) + 0.15
    if failure is not None:
        z_hi = max(z_hi, failure.state[1] + 0.17 + label_height + 0.05)
    view_h = z_hi - z_lo
    # Meshcat keeps the view's left edge and height and widens it to the window's aspect: draw the terrain far
    # enough right for windows up to 5:1.
    if follow:
        view = (-LEAD, -LEAD + 16 / 9 * view_h, z_lo, z_hi)
        draw_lo, draw_hi = x_lo - LEAD - 1.0, x_hi - LEAD + 5.0 * view_h
    else:  # frame the whole run: at least as tall as the run's width at 16:9
        width = x_hi - x_lo + 1.0
        extra = max(width * 9 / 16 - view_h, 0.0)
        view = (x_lo - 0.5, x_lo - 0.5 + width, z_lo - extra / 2, z_hi + extra / 2)
        draw_lo, draw_hi = x_lo - 1.0, x_lo - 0.5 + 5.0 * (view_h + extra)

    root = prefix.rstrip("/")
    meshcat.Delete(root)
    meshcat.Set2dRenderMode(RigidTransform([0.0, -5.0, 0.0]), *view)
    for light in ("SpotLight", "PointLightNegativeX", "PointLightPositiveX", "FillLight"):
        meshcat.SetProperty(f"/Lights/{light}/<object>", "intensity", 0.0)
    meshcat.SetProperty("/Lights/AmbientLight/<object>", "intensity", math.pi)  # flat colours

    bottom = floor - 2.0 * view_h  # the boxes go on below the view
    for i, (left, right, top) in enumerate(terrain_boxes(terrain, draw_lo, draw_hi, bottom)):
        path = f"{root}/world/terrain/{i}"
        meshcat.SetObject(path, Box(right - left, 0.4, top - bottom), _rgba(TERRAIN_RGB))
        meshcat.SetTransform(path, _pose((left + right) / 2, _Y_TERRAIN, (top + bottom) / 2))
    step = max(1, times.size // 2000)
    path_xyz = np.column_stack([states[::step, 0], np.full(len(states[::step]), _Y_MARK / 2), states[::step, 1]])
    meshcat.SetLine(f"{root}/world/path", np.asfortranarray(path_xyz.T), 2.0, _rgba(PATH_RGB))
    size = 0.05 * params.leg_length / 0.5
    for i, (x, z) in enumerate(planned):
        path = f"{root}/world/planned/{i}"
        meshcat.SetObject(path, Box(size, 0.01, size), _rgba(PLANNED_RGB))
        meshcat.SetTransform(path, _pose(x, _Y_FOOT, z + 0.9 * size, math.pi / 4))
    cross = np.array([[(-1, 0), (1, 0)], [(0, -1), (0, 1)]]) * size
    for i, (x, z) in enumerate(predicted):
        meshcat.SetTriangleMesh(f"{root}/world/predicted/{i}", *_stroke_mesh(cross + (x, z), size / 3),
                                _rgba(PREDICTED_RGB))
        meshcat.SetTransform(f"{root}/world/predicted/{i}", _pose(0.0, _Y_MARK, 0.0))
    touchdowns = [e for e in sim.events if e.kind == "touchdown" and e.foot is not None]
    for i, e in enumerate(touchdowns):
        path = f"{root}/world/executed/{i}"
        meshcat.SetObject(path, Sphere(0.6 * size), _rgba(EXECUTED_RGB))
        meshcat.SetTransform(path, _pose(e.foot[0], _Y_FOOT + 0.02, e.foot[1]))
    if failure is not None:
        x, z = failure.state[0], failure.state[1]
        bars = np.array([[(-1, -1), (1, 1)], [(-1, 1), (1, -1)]]) * 0.09 + (x, z)
        meshcat.SetTriangleMesh(f"{root}/world/failure/x", *_stroke_mesh(bars, 0.025), _rgba(FAILURE_RGB))
        name = sim.failure.name if sim.failure is not None else "FAILURE"
        letters, width = text_segments(name, label_height)
        origin = (x - min(width / 2, 0.3), z + 0.17)
        meshcat.SetTriangleMesh(f"{root}/world/failure/label", *_stroke_mesh(letters + origin, 0.016),
                                _rgba(FAILURE_RGB))
        meshcat.SetTransform(f"{root}/world/failure", _pose(0.0, _Y_FAIL, 0.0))

    hopper = f"{root}/world/hopper"
    meshcat.SetObject(f"{hopper}/body", Sphere(0.12 * params.leg_length), _rgba(BODY_RGB))
    meshcat.SetTriangleMesh(f"{hopper}/leg/spring", *_stroke_mesh(_spring_segments(), 0.012), _rgba(LEG_RGB))
    meshcat.SetObject(f"{hopper}/leg/foot", Sphere(0.018), _rgba(LEG_RGB))
    meshcat.SetTransform(hopper, _pose(0.0, _Y_LEG, 0.0))

    animation = MeshcatAnimation(fps)
    animation.set_loop_mode(MeshcatAnimation.LoopMode.kLoopOnce)
    animation.set_clamp_when_finished(True)
    t0, t_end = float(times[0]), float(times[-1])
    n_frames = int(math.floor((t_end - t0) / speed * fps)) + 2  # the last frame shows the end of the run
    failure_foot = failure.foot if failure is not None else None
    shown_from = {f"{root}/world/executed/{i}": e.time for i, e in enumerate(touchdowns)}
    if failure is not None:
        shown_from[f"{root}/world/failure"] = failure.time
    for k in range(n_frames):
        t = min(t0 + k * speed / fps, t_end)
        i = min(int(np.searchsorted(times, t, side="right")) - 1, times.size - 1)
        x, z = (float(np.interp(t, times, states[:, c])) for c in (0, 1))
        angle, length = leg_geometry(x, z, sim.hybrid[i], params, failure_foot)
        poses = {f"{hopper}/body": _pose(x, _Y_BODY - _Y_LEG, z), f"{hopper}/leg": _pose(x, 0.0, z, -angle),
                 f"{hopper}/leg/foot": _pose(0.0, 0.0, -length)}
        if follow:
            poses[f"{root}/world"] = RigidTransform([-x, 0.0, 0.0])
        props = [(f"{hopper}/leg/spring", "scale", [1.0, 1.0, length])]
        props += [(p, "visible", t >= t_shown) for p, t_shown in shown_from.items()]
        for p, pose in poses.items():
            animation.SetTransform(k, p, pose)
            if k == 0:
                meshcat.SetTransform(p, pose)
        for p, name, value in props:
            animation.SetProperty(k, p, name, value)
            if k == 0:
                meshcat.SetProperty(p, name, value)
    meshcat.SetAnimation(animation)
    return n_frames


def _header(sim: SimulationResult, title: str | None, n_planned: int, n_predicted: int, speed: float, fps: float):
    """The HTML header: the title, the outcome, and what each colour means."""
    def swatch(rgb, text):
        colour = "#" + "".join(f"{round(255 * c):02x}" for c in rgb)
        return (f'<span style="display:inline-block;width:10px;height:10px;background:{colour};'
                f'margin:0 3px 0 10px"></span>{html.escape(text)}')

    hops = sum(1 for e in sim.events if e.kind == "touchdown")
    if sim.failure is not None:
        e = sim.failure_event
        outcome = f"failed: {sim.failure.name} at t = {e.time:.2f} s, x = {e.state[0]:.2f} m"
    else:
        outcome = "no failure"
    pace = "real time" if speed == 1 else f"{speed:g} x real time"
    items = [swatch(TERRAIN_RGB, "terrain"), swatch(BODY_RGB, "body"), swatch(LEG_RGB, "leg (spring)"),
             swatch(EXECUTED_RGB, "executed footholds")]
    if n_planned:
        items.append(swatch(PLANNED_RGB, "planned footholds"))
    if n_predicted:
        items.append(swatch(PREDICTED_RGB, "predicted apexes"))
    if sim.failure is not None:
        items.append(swatch(FAILURE_RGB, "failure"))
    line1 = (f"<b>{html.escape(title or 'SLIP hopper replay')}</b> &nbsp; {hops} touchdowns, "
             f"{html.escape(outcome)} &nbsp; <i>{pace}, {fps:g} fps; Open Controls &gt; Animations to replay</i>")
    return (f'<div id="drakeslip-header" style="height:{HEADER_PX}px;box-sizing:border-box;padding:6px 10px;'
            f'font:13px/20px sans-serif;white-space:nowrap;overflow:hidden;background:#f4f4f4;'
            f'border-bottom:1px solid #bbb">{line1}<br>{"".join(items)}</div>')


def write_replay(sim: SimulationResult, path, planned_footholds=None, predicted_apexes=None, title: str | None = None,
                 *, fps: float = 30.0, speed: float = 1.0, follow: bool = True) -> Path:
    """Write a self-contained HTML replay of ``sim`` (see ``draw_replay``) to ``path``; returns the Path."""
    from pydrake.geometry import Meshcat

    path = Path(path)
    meshcat = Meshcat()
    try:
        draw_replay(meshcat, sim, planned_footholds, predicted_apexes, fps=fps, speed=speed, follow=follow)
        page = meshcat.StaticHtml()
    finally:
        del meshcat
    counts = [0 if v is None else len(v) for v in (planned_footholds, predicted_apexes)]
    header = _header(sim, title, *counts, speed, fps)
    name = html.escape(title or "SLIP hopper replay")
    page = page.replace("<title>Drake MeshCat</title>", f"<title>{name}</title>", 1)
    page = page.replace('<div id="meshcat-pane">', header + '\n  <div id="meshcat-pane">', 1)
    head, tail, end = page.rpartition("</body>")
    style = f"<style>#meshcat-pane {{ height: calc(100vh - {HEADER_PX}px) !important; }}</style>\n"
    page = head + style + tail + end if tail else page
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(page)
    return path
