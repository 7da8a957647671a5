"""The controller's Newton polish, compiled: ``fast_controller.aim_rows`` (``StepLengthController.leg_angles`` with
``refine``) polishes every row's angle with it."""
from __future__ import annotations

import math

from drakeslip.compiled import compiled

NEWTON_STEPS = 6


@compiled()
def polish_one(v, d, target_i, th, leg_length, gravity, max_angle):
    """Newton steps on the closed-form touchdown offset(theta) = L0 sin(theta) + xdot T(theta), with the fall time
    T = sqrt(2 (drop - L0 cos(theta)) / g); d offset / d theta = L0 cos(theta) + xdot L0 sin(theta) / (g T), for
    one row's speed ``v``, drop ``d`` and target offset, from the network's ``th``. When the body is less than L0
    above the landing surface (a higher step), the foot only clears it for |theta| > acos(drop / L0): iterates are
    kept on that side (a step that would cross moves half way to the boundary), so a hop planned just above the
    step's top is reproduced, not tripped."""
    side = -1.0 if target_i < 0 else 1.0
    boundary = side * math.acos(min(max(d / leg_length, -1.0), 1.0))  # foot level with the surface at apex
    if not d - leg_length * math.cos(th) > 1e-12:
        th = boundary + side * 1e-4
    for _ in range(NEWTON_STEPS):
        fall = d - leg_length * math.cos(th)
        ok = fall > 1e-12
        t = math.sqrt(2 * (fall if ok else 1.0) / gravity)
        slope = leg_length * math.cos(th) + v * leg_length * math.sin(th) / (gravity * t)
        ok = ok and slope > 1e-3
        step = (leg_length * math.sin(th) + v * t - target_i) / slope if ok else 0.0
        new = min(max(th - min(max(step, -0.1), 0.1), -max_angle), max_angle)
        th = new if d - leg_length * math.cos(new) > 1e-12 else 0.5 * (th + boundary)
    return th
