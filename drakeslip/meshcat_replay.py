"""Replays of simulated SLIP hops in Drake's Meshcat, saved as self-contained HTML (kept apart from the dynamics).

``draw_replay`` draws a SimulationResult into a given ``pydrake.geometry.Meshcat`` and sets an animation of it;
``write_replay`` does that in a fresh Meshcat and writes ``Meshcat.StaticHtml()`` (three.js and the scene embedded:
it opens offline, no server) with a header naming the run, its outcome and what each colour means.

The scene, its markers and the camera are ``drakeslip.replay_scene``'s (shared with the multibody robot's
replay); the hopper is the SLIP's: the body (a sphere) and the leg (a zigzag spring from hip to foot, drawn at its
actual length: compressing in stance, at rest length when deployed in flight, short and straight down when
retracted).

The animation plays once at ``speed`` times real time (1 = real time) with frames at ``fps`` sampled from the
logged states (body interpolated between samples, the hybrid state of the latest sample), and stops on its last
frame; Meshcat's "Open Controls" menu replays it. With ``follow`` the view tracks the body (the scene slides under
a fixed camera, the body kept ``replay_scene.LEAD`` metres right of the left edge, the terrain ahead in view);
without it the whole run is framed at once.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from drakeslip.slip_hopper import HybridState, Mode
from drakeslip.replay_scene import Y_HOPPER, Scene, animate, draw_scene, legend, points, pose, rgba, stroke_mesh, \
    write_page
from drakeslip.simulation import SimulationResult

BODY_RGB = (0.12, 0.31, 0.60)   # the body's own colour: no marker, the terrain or the leg is near it
LEG_RGB = (0.15, 0.15, 0.15)
RETRACTED_FRACTION = 0.35  # a retracted leg is drawn this fraction of its rest length, straight down (as viz)
_MODE, _DEPLOYED, _ANGLE = (HybridState._fields.index(f) for f in ("mode", "leg_deployed", "leg_angle"))
_FOOT_X, _FOOT_Z = HybridState._fields.index("foot_x"), HybridState._fields.index("foot_z")


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


def _scene(sim: SimulationResult, planned_footholds, predicted_apexes) -> Scene:
    failure = sim.failure_event
    touchdowns = [(e.time, *e.foot) for e in sim.events if e.kind == "touchdown" and e.foot is not None]
    name = sim.failure.name if sim.failure is not None else "FAILURE"
    return Scene(sim.terrain, sim.times, sim.states[:, :2], np.array(touchdowns, dtype=float).reshape(-1, 3),
                 points(planned_footholds, sim.terrain), points(predicted_apexes, sim.terrain),
                 None if failure is None else (failure.time, failure.state[0], failure.state[1], name),
                 0.05 * sim.params.leg_length / 0.5, 0.15)


def draw_replay(meshcat, sim: SimulationResult, planned_footholds=None, predicted_apexes=None, *, fps: float = 30.0,
                speed: float = 1.0, follow: bool = True, prefix: str = "/drakeslip") -> int:
    """Draw ``sim`` into ``meshcat`` under ``prefix`` (deleting what was there), set the 2-D camera and ambient-only
    lights, and set (replacing any) the Meshcat animation of the run: ``speed`` times real time, ``fps`` frames
    per second. ``planned_footholds`` are x positions (on the terrain) or (x, z) pairs; ``predicted_apexes`` are
    ApexStates or (x, z, ...) tuples. Returns the number of animation frames."""
    from pydrake.geometry import Sphere

    if sim.times.size == 0:
        raise ValueError("the result has no logged trajectory (simulate with log=True)")
    scene = _scene(sim, planned_footholds, predicted_apexes)
    root = prefix.rstrip("/")
    shown_from = draw_scene(meshcat, scene, root, follow)
    hopper, params = f"{root}/world/hopper", sim.params
    meshcat.SetObject(f"{hopper}/body", Sphere(0.12 * params.leg_length), rgba(BODY_RGB))
    meshcat.SetTriangleMesh(f"{hopper}/leg/spring", *stroke_mesh(_spring_segments(), 0.012), rgba(LEG_RGB))
    meshcat.SetObject(f"{hopper}/leg/foot", Sphere(0.018), rgba(LEG_RGB))
    meshcat.SetTransform(hopper, pose(0.0, Y_HOPPER, 0.0))
    times, states = sim.times, sim.states
    failure_foot = sim.failure_event.foot if sim.failure_event is not None else None

    def hopper_at(t):
        i = min(int(np.searchsorted(times, t, side="right")) - 1, times.size - 1)
        x, z = (float(np.interp(t, times, states[:, c])) for c in (0, 1))
        angle, length = leg_geometry(x, z, sim.hybrid[i], params, failure_foot)
        poses = {f"{hopper}/body": pose(x, -0.02, z), f"{hopper}/leg": pose(x, 0.0, z, -angle),
                 f"{hopper}/leg/foot": pose(0.0, 0.0, -length)}
        return poses, [(f"{hopper}/leg/spring", "scale", [1.0, 1.0, length])]

    return animate(meshcat, scene, hopper_at, shown_from, root, fps=fps, speed=speed, follow=follow)


def write_replay(sim: SimulationResult, path, planned_footholds=None, predicted_apexes=None, title: str | None = None,
                 *, fps: float = 30.0, speed: float = 1.0, follow: bool = True) -> Path:
    """Write a self-contained HTML replay of ``sim`` (see ``draw_replay``) to ``path``; returns the Path."""
    from pydrake.geometry import Meshcat

    meshcat = Meshcat()
    try:
        draw_replay(meshcat, sim, planned_footholds, predicted_apexes, fps=fps, speed=speed, follow=follow)
        hops = sum(1 for e in sim.events if e.kind == "touchdown")
        if sim.failure is not None:
            e = sim.failure_event
            outcome = f"failed: {sim.failure.name} at t = {e.time:.2f} s, x = {e.state[0]:.2f} m"
        else:
            outcome = "no failure"
        items = legend(_scene(sim, planned_footholds, predicted_apexes),
                       [(BODY_RGB, "body"), (LEG_RGB, "leg (spring)")])
        return write_page(meshcat, path, title or "SLIP hopper replay", f"{hops} touchdowns, {outcome}", items,
                          speed=speed, fps=fps)
    finally:
        del meshcat
