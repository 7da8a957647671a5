"""Replays of the spatial hopper's runs in Drake's Meshcat, saved as self-contained HTML (the 3-D counterpart of
``drakeslip.meshcat_replay``, kept apart from the dynamics).

``draw_replay3d`` draws a SimulationResult3D into a given ``pydrake.geometry.Meshcat`` and sets an animation of it;
``write_replay3d`` does that in a fresh Meshcat and writes ``Meshcat.StaticHtml()`` (three.js and the scene embedded:
it opens offline, no server) under the 2-D replay's header (``drakeslip.replay_scene.write_page``).

The scene: the height map's cells within CROP_MARGIN of the run as boxes coloured by height as in
``drakeslip.spatial.viz``'s figure (equal cells merged into rectangles, ``heightmap.merge_cells``; holes left open over
a dark floor), the body's path, the planned footholds (cyan diamonds) and the executed ones (orange balls, each shown
from its touchdown on) in the 2-D replay's colours, the failure (a red X with its name, from its time on), and the
hopper: the body a blue sphere, the leg a rod to the foot (to the pinned foot in stance, at rest length along the
commanded (pitch, roll) when deployed in flight, short and straight down when retracted).

A perspective camera looks ahead from behind the hopper, to its left and above it. The world slides under it as
the 2-D replay's does with ``follow``, by the body's x and y (not z: the hops are seen), so the body stays at one
place on the screen for a run of any length; the orbit controls still turn the view about it.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.colors import to_rgb

from drakeslip.hybrid_hopper import Mode
from drakeslip.meshcat_replay import BODY_RGB, LEG_RGB, RETRACTED_FRACTION
from drakeslip.replay_scene import EXECUTED_RGB, FAILURE_RGB, PATH_RGB, PLANNED_RGB, play, rgba, stroke_mesh, \
    swatch, text_segments, write_page
from drakeslip.spatial.dynamics import leg_offset
from drakeslip.spatial.heightmap import HeightMap, merge_cells
from drakeslip.spatial.simulation import SimulationResult3D
from drakeslip.spatial.slip_hopper import HybridState3D
from drakeslip.spatial.viz import HOLE_COLOR, crop, foothold_points, ground_colormap, height_norm

CROP_MARGIN = 1.5      # [m] of the map drawn around the run (its path and its planned footholds)
FLOOR_DEPTH = 0.3      # [m] the boxes reach this far below the lowest solid cell drawn; the dark floor is there
MARKER = 0.08          # [m] the foothold markers' size
BODY_RADIUS = 0.08     # [m]
LEG_RADIUS = 0.012     # [m]
# The camera relative to the body's start, in the frame that slides with the body: behind, left and above it,
# looking at a point ahead of the body and below it (the landing ahead in view).
CAMERA, TARGET = (-2.6, -2.0, 2.4), (0.9, 0.2, 0.2)
_MODE, _DEPLOYED, _PITCH, _ROLL = (HybridState3D._fields.index(f) for f in ("mode", "leg_deployed", "leg_pitch",
                                                                           "leg_roll"))
_FOOT = [HybridState3D._fields.index(f) for f in ("foot_x", "foot_y", "foot_z")]


def height_map_boxes(height_map: HeightMap, points, margin: float = CROP_MARGIN) -> list[tuple]:
    """(x0, x1, y0, y1, top) of the merged boxes of ``height_map``'s cells within ``margin`` of ``points``'
    bounding box (``drakeslip.spatial.viz.crop``)."""
    j0, j1, i0, i1 = crop(height_map, points, margin)
    (x0, y0), c = height_map.origin, height_map.cell
    return [(x0 + (i0 + a) * c, x0 + (i0 + b) * c, y0 + (j0 + lo) * c, y0 + (j0 + hi) * c, h)
            for lo, hi, a, b, h in merge_cells(height_map.heights[j0:j1, i0:i1])]


def leg_vector(body, hybrid_row, params, failure_foot=None) -> tuple:
    """(dx, dy, dz) from the body to where the foot is drawn: the pinned foot in stance (and at a failure that has
    one), at rest length along the commanded (pitch, roll) when deployed in flight, else retracted straight
    down."""
    mode = int(hybrid_row[_MODE])
    foot = tuple(hybrid_row[_FOOT]) if mode == Mode.STANCE else None
    if mode == Mode.FAILED and failure_foot is not None:
        foot = failure_foot
    if foot is not None:
        return tuple(float(f - b) for f, b in zip(foot, body))
    if hybrid_row[_DEPLOYED]:
        return tuple(float(d) for d in leg_offset(hybrid_row[_PITCH], hybrid_row[_ROLL], params.as_array()))
    return 0.0, 0.0, -RETRACTED_FRACTION * params.leg_length


def rod_mesh(radius: float, sides: int = 8):
    """Vertices (3, N) and faces (3, M) of a closed prism of ``radius`` from z = 0 down to z = -1 (the leg node
    scales it along z to the leg's length)."""
    angles = 2 * np.pi * np.arange(sides) / sides
    ring = np.column_stack([radius * np.cos(angles), radius * np.sin(angles)])
    vertices = np.vstack([np.column_stack([ring, np.zeros(sides)]), np.column_stack([ring, -np.ones(sides)])])
    k, k1 = np.arange(sides), (np.arange(sides) + 1) % sides
    sides_faces = np.concatenate([np.column_stack([k, k1, k1 + sides]), np.column_stack([k, k1 + sides, k + sides])])
    caps = np.concatenate([np.column_stack([np.zeros(sides - 2, int), k[1:-1], k[2:]]),
                           np.column_stack([np.full(sides - 2, sides), k[2:] + sides, k[1:-1] + sides])])
    faces = np.concatenate([sides_faces, caps]).astype(np.int32)
    return np.asfortranarray(vertices.T), np.asfortranarray(faces.T)


def leg_pose(body, vector):
    """The leg node's pose: at the body, its -z axis along ``vector`` (a zero vector: straight down)."""
    from pydrake.math import RigidTransform, RotationMatrix

    v = np.asarray(vector, dtype=float)
    rotation = RotationMatrix.MakeFromOneVector(-v, 2) if np.linalg.norm(v) > 1e-9 else RotationMatrix()
    return RigidTransform(rotation, np.asarray(body, dtype=float))


def facing_camera(origin):
    """A pose at ``origin`` whose x-z plane faces the camera (turned about z): for the flat failure label."""
    from pydrake.math import RigidTransform, RotationMatrix

    return RigidTransform(RotationMatrix.MakeZRotation(math.atan2(CAMERA[0], -CAMERA[1])), origin)


def draw_terrain(meshcat, height_map: HeightMap, points, world: str) -> None:
    """The map's cells around ``points`` as boxes coloured by height down to a dark floor (``height_map_boxes``);
    nothing where they are all holes."""
    from pydrake.geometry import Box
    from pydrake.math import RigidTransform

    boxes = height_map_boxes(height_map, points)
    if not boxes:  # nothing but holes around the run
        return
    tops = np.array([b[4] for b in boxes])
    floor = float(tops.min()) - FLOOR_DEPTH
    cmap, norm = ground_colormap(), height_norm(tops)
    for k, (x0, x1, y0, y1, top) in enumerate(boxes):
        meshcat.SetObject(f"{world}/terrain/{k}", Box(x1 - x0, y1 - y0, top - floor), rgba(cmap(norm(top))[:3]))
        meshcat.SetTransform(f"{world}/terrain/{k}", RigidTransform([(x0 + x1) / 2, (y0 + y1) / 2, (top + floor) / 2]))
    x_lo, y_lo = min(b[0] for b in boxes), min(b[2] for b in boxes)
    x_hi, y_hi = max(b[1] for b in boxes), max(b[3] for b in boxes)
    meshcat.SetObject(f"{world}/terrain/floor", Box(x_hi - x_lo, y_hi - y_lo, 0.02), rgba(to_rgb(HOLE_COLOR)))
    meshcat.SetTransform(f"{world}/terrain/floor", RigidTransform([(x_lo + x_hi) / 2, (y_lo + y_hi) / 2, floor - 0.01]))


def draw_markers(meshcat, path, touchdowns, failure, planned: np.ndarray, world: str) -> dict:
    """The body's ``path`` ((N, 3)), the ``planned`` footholds, the executed ones (``touchdowns``: (t, x, y, z) each)
    and the ``failure`` ((t, (x, y, z) of the body, name) or None). Returns {path: time} of the markers shown from a
    time on (the executed footholds, the failure)."""
    from pydrake.geometry import Box, Sphere
    from pydrake.math import RigidTransform, RotationMatrix

    path = np.asarray(path, dtype=float)
    step = max(1, len(path) // 2000)
    meshcat.SetLine(f"{world}/path", np.asfortranarray(path[::step, :3].T), 2.0, rgba(PATH_RGB))
    diamond = RotationMatrix.MakeZRotation(math.pi / 4)
    for k, (x, y, z) in enumerate(planned[np.isfinite(planned).all(axis=1)]):
        meshcat.SetObject(f"{world}/planned/{k}", Box(MARKER, MARKER, 0.02), rgba(PLANNED_RGB))
        meshcat.SetTransform(f"{world}/planned/{k}", RigidTransform(diamond, [x, y, z + 0.012]))
    shown_from = {}
    for k, (t, *foot) in enumerate(touchdowns):
        meshcat.SetObject(f"{world}/executed/{k}", Sphere(0.45 * MARKER), rgba(EXECUTED_RGB))
        meshcat.SetTransform(f"{world}/executed/{k}", RigidTransform([float(v) for v in foot]))
        shown_from[f"{world}/executed/{k}"] = float(t)
    if failure is not None:
        t, body, name = failure
        bars = np.array([[(-1, -1), (1, 1)], [(-1, 1), (1, -1)]]) * 0.12
        meshcat.SetTriangleMesh(f"{world}/failure/x", *stroke_mesh(bars, 0.03), rgba(FAILURE_RGB))
        letters, width = text_segments(name, 0.12)
        label = stroke_mesh(letters + (-min(width / 2, 0.4), 0.22), 0.02)
        meshcat.SetTriangleMesh(f"{world}/failure/label", *label, rgba(FAILURE_RGB))
        meshcat.SetTransform(f"{world}/failure", facing_camera([float(v) for v in body]))
        shown_from[f"{world}/failure"] = float(t)
    return shown_from


def set_view(meshcat, ground: float) -> None:
    """The perspective camera at CAMERA looking at TARGET above the ``ground`` level under the start, in the frame
    that slides with the body; no grid or axes (the grid at z = 0 would cut through the ground)."""
    from pydrake.geometry import Meshcat

    meshcat.SetCamera(Meshcat.PerspectiveCamera(fov=60.0))
    meshcat.SetCameraPose(np.add(CAMERA, (0.0, 0.0, ground)), np.add(TARGET, (0.0, 0.0, ground)))
    meshcat.SetProperty("/Grid", "visible", False)
    meshcat.SetProperty("/Axes", "visible", False)


def animate3d(meshcat, result: SimulationResult3D, shown_from: dict, root: str, *, fps: float, speed: float) -> int:
    """Set (replacing any) the Meshcat animation of the run at ``speed`` times real time, ``fps`` frames a second,
    played once and held on its last frame (``drakeslip.replay_scene.play``): each frame the hopper (body
    interpolated between the logged samples, the leg of the latest sample's hybrid state), the world slid under the
    camera by the body's x and y, each marker of ``shown_from`` visible from its time on. Frame 0 is also set as the
    scene's state. Returns the number of frames."""
    from pydrake.math import RigidTransform

    times, states, hopper = result.times, result.states, f"{root}/world/hopper"
    failure_foot = result.failure_event.foot if result.failure_event is not None else None

    def frame_at(t):
        i = min(int(np.searchsorted(times, t, side="right")) - 1, times.size - 1)
        body = [float(np.interp(t, times, states[:, c])) for c in range(3)]
        leg = leg_vector(body, result.hybrid[i], result.params, failure_foot)
        length = float(np.linalg.norm(leg))
        poses = {f"{root}/world": RigidTransform([-body[0], -body[1], 0.0]), f"{hopper}/body": RigidTransform(body),
                 f"{hopper}/leg": leg_pose(body, leg), f"{hopper}/leg/foot": RigidTransform([0.0, 0.0, -length])}
        return poses, [(f"{hopper}/leg/rod", "scale", [1.0, 1.0, length])]

    return play(meshcat, times[0], times[-1], frame_at, shown_from, fps=fps, speed=speed)


def draw_replay3d(meshcat, result: SimulationResult3D, planned_footholds=None, *, fps: float = 30.0,
                  speed: float = 1.0, prefix: str = "/drakeslip") -> int:
    """Draw ``result`` into ``meshcat`` under ``prefix`` (deleting what was there), set the camera that follows
    the hopper, and set (replacing any) the Meshcat animation of the run: ``speed`` times real time, ``fps``
    frames per second. ``planned_footholds`` are (x, y) (on the map) or (x, y, z) rows. Returns the number of
    animation frames."""
    from pydrake.geometry import Sphere

    if result.times.size == 0:
        raise ValueError("the result has no logged trajectory (simulate3d with log=True)")
    root = prefix.rstrip("/")
    world, height_map = f"{root}/world", result.height_map
    planned = foothold_points(planned_footholds, height_map)
    meshcat.Delete(root)
    x, y = result.states[0, :2]
    set_view(meshcat, float(np.nan_to_num(height_map.height_at(x, y))))
    draw_terrain(meshcat, height_map, np.concatenate([result.states[:, :2], planned[:, :2]]), world)
    touchdowns = [(e.time, *e.foot) for e in result.events if e.kind == "touchdown" and e.foot is not None]
    e = result.failure_event
    failure = None if e is None else (e.time, e.state[:3], result.failure.name)
    shown_from = draw_markers(meshcat, result.states[:, :3], touchdowns, failure, planned, world)
    hopper = f"{world}/hopper"
    meshcat.SetObject(f"{hopper}/body", Sphere(BODY_RADIUS), rgba(BODY_RGB))
    meshcat.SetTriangleMesh(f"{hopper}/leg/rod", *rod_mesh(LEG_RADIUS), rgba(LEG_RGB))
    meshcat.SetObject(f"{hopper}/leg/foot", Sphere(1.6 * LEG_RADIUS), rgba(LEG_RGB))
    return animate3d(meshcat, result, shown_from, root, fps=fps, speed=speed)


def legend_items(hopper_items, planned: bool, failed: bool) -> list:
    """The page's legend: the ground, holes, the hopper's parts (``hopper_items``: (rgb, name) each) and the markers
    the scene has."""
    items = [(ground_colormap()(0.5)[:3], "ground (green low, brown high)"), (to_rgb(HOLE_COLOR), "hole"),
             *hopper_items, (PATH_RGB, "body path"), (EXECUTED_RGB, "executed footholds")]
    if planned:
        items.append((PLANNED_RGB, "planned footholds"))
    if failed:
        items.append((FAILURE_RGB, "failure"))
    return [swatch(rgb, text) for rgb, text in items]


def write_replay3d(result: SimulationResult3D, path, planned_footholds=None, title: str | None = None, *,
                   speed: float = 1.0, fps: float = 30.0) -> Path:
    """Write a self-contained HTML replay of ``result`` (see ``draw_replay3d``) to ``path``; returns the Path."""
    from pydrake.geometry import Meshcat

    meshcat = Meshcat()
    try:
        draw_replay3d(meshcat, result, planned_footholds, fps=fps, speed=speed)
        if result.failure is not None:
            x, y = result.failure_event.state[:2]
            outcome = (f"failed: {result.failure.name} at t = {result.failure_event.time:.2f} s, "
                       f"(x, y) = ({x:.2f}, {y:.2f}) m")
        else:
            outcome = "no failure"
        items = legend_items([(BODY_RGB, "body"), (LEG_RGB, "leg")],
                             planned_footholds is not None and len(planned_footholds) > 0, result.failure is not None)
        return write_page(meshcat, path, title or "spatial SLIP hopper replay",
                          f"{len(result.footholds)} touchdowns, {outcome}", items, speed=speed, fps=fps)
    finally:
        del meshcat
