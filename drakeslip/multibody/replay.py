"""Replays of multibody runs in Meshcat, saved as self-contained HTML: the robot's own geometry (body box, upper
leg, lower leg and foot, as in ``hopper.sdf``) over the terrain's boxes, animated from a logged trajectory
(``HopLog`` with ``trajectory=True``) by Drake's ``MeshcatVisualizer`` recording, seen side-on in Meshcat's 2-D
mode. The page has a header naming the run and its outcome."""
from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from drakeslip.multibody.robot import RobotParams
from drakeslip.terrain import Terrain

HEADER_PX = 40


def write_robot_replay(log, terrain: Terrain, path, robot: RobotParams | None = None, title: str | None = None,
                       fps: float = 30.0) -> Path:
    """Write the HTML replay of ``log`` (positions at ``log.times``) on ``terrain`` to ``path``; returns it."""
    from pydrake.geometry import Meshcat, MeshcatVisualizer, MeshcatVisualizerParams, Role
    from pydrake.math import RigidTransform
    from pydrake.systems.framework import DiagramBuilder

    from drakeslip.multibody.diagram import add_robot_and_terrain

    if not log.times:
        raise ValueError("the run has no trajectory to replay: run it with trajectory=True")
    robot = robot or RobotParams()
    builder = DiagramBuilder()
    plant, scene_graph, _, _ = add_robot_and_terrain(builder, terrain, robot)
    meshcat = Meshcat()
    visualizer = MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat,
                                                MeshcatVisualizerParams(role=Role.kIllustration))
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    times = np.asarray(log.times)
    positions = np.asarray(log.positions)
    xs = positions[:, 0]
    x_lo, x_hi = float(xs.min()) - 1.0, float(xs.max()) + 1.0
    meshcat.Set2dRenderMode(RigidTransform([0.0, -5.0, 0.0]), x_lo, x_hi, -0.5, 1.8)
    recording = visualizer.StartRecording(set_transforms_while_recording=False)
    for t in np.arange(times[0], times[-1] + 1e-9, 1.0 / fps):
        k = min(int(np.searchsorted(times, t)), len(times) - 1)
        context.SetTime(float(t))
        plant.SetPositions(plant_context, positions[k])
        diagram.ForcedPublish(context)
    del recording
    visualizer.StopRecording()
    visualizer.PublishRecording()
    page = meshcat.StaticHtml()
    failure = log.failure
    outcome = "no failure" if failure is None else \
        f"failed: {failure.mode.name} ({failure.what}) at t = {failure.time:.2f} s, x = {failure.x:.2f} m"
    name = html.escape(title or "multibody hopper replay")
    header = (f'<div id="drakeslip-header" style="height:{HEADER_PX}px;box-sizing:border-box;padding:8px 10px;'
              f'font:13px/20px sans-serif;white-space:nowrap;overflow:hidden;background:#f4f4f4;'
              f'border-bottom:1px solid #bbb"><b>{name}</b> &nbsp; {len(log.footholds)} touchdowns, '
              f'{html.escape(outcome)}; largest body pitch {log.max_pitch:.2f} rad</div>')
    page = page.replace("<title>Drake MeshCat</title>", f"<title>{name}</title>", 1)
    page = page.replace('<div id="meshcat-pane">', header + '\n  <div id="meshcat-pane">', 1)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(page)
    return path
