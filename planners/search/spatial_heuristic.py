"""The terrain heuristic on a height map (``planners.search.heuristic`` in the plane; Raibert's foot placement):
each hop keeps the apex speed and height, the foot placed at the neutral point for its drop along the body's
velocity, moved across it to turn the velocity toward the target (Raibert's velocity term), and snapped to the
nearest safe cell when it falls in a hole or near an edge. It never simulates while planning (zero step-map calls):
the gait table and the turning gain are a one-off calibration per hopper, as a robot's gait table is."""
from __future__ import annotations

import functools
import math

import numpy as np

from drakeslip.params import SlipParams
from drakeslip.spatial.heightmap import HeightMap
from drakeslip.spatial.stepmap import step_batch3d
from drakeslip.terrain import LEVEL_TOLERANCE
from drakeslip.units import units_of

from planners.base import FootstepSequence, Plan
from planners.core.spatial_tree import reaches
from planners.search.gait import interpolate, neutral_gait
from planners.search.spatial_problem import SpatialProblem

MAX_TURN = 0.1    # [rad] the most the heading turns toward the target in one hop
PROBE = 0.05      # [m] the sideways foot offset the turning gain is measured with (the paper's hopper's)
MAX_HOPS = 200    # a plan longer than this goes in circles


@functools.cache
def turning_gain(params: SlipParams) -> float:
    """The change of sideways speed per metre the foot is placed sideways of the neutral point [1/s] (negative: a
    foot to the left pushes the body right), measured once per hopper on flat ground at the paper's 1.5 m/s and 0.9 m
    apex in its units."""
    units = units_of(params)
    free = params.with_friction(10.0)
    v, z = 1.5 * units.speed, 0.9 * units.length
    offset_table, _ = neutral_gait(free.with_friction(1.0))
    ahead = interpolate(offset_table, v, z)
    flat = HeightMap.flat(0.0, 0.05 * units.length, (-5 * units.length, -5 * units.length),
                          (20 * units.length, 10 * units.length))
    probe = PROBE * units.length
    t = math.sqrt(2 * (z - params.leg_length) / params.gravity)
    angles = []
    for side in (-probe, probe):
        ox, oy = ahead - v * t, side   # the foot's offset from the body at the apex lands it at (ahead, side)
        oz = -math.sqrt(max(params.leg_length ** 2 - ox * ox - oy * oy, 1e-12))
        angles.append((math.atan2(ox, -oz), math.asin(oy / params.leg_length)))
    hops = step_batch3d((0.0, 0.0, z, v, 0.0), angles, flat, free)
    vy = hops.end_state[:, 4]
    return float((vy[1] - vy[0]) / (2 * probe)) if hops.ok.all() else -1.0 / units.time


def safe(height_map: HeightMap, x: np.ndarray, y: np.ndarray, margin: float) -> np.ndarray:
    """Solid ground at (x, y) and at the eight points ``margin`` around it, all of one level."""
    h = height_map.height_at(x, y)
    ok = ~np.isnan(h)
    for k in range(8):
        a = 0.25 * math.pi * k
        around = height_map.height_at(x + margin * math.cos(a), y + margin * math.sin(a))
        ok &= ~np.isnan(around) & (np.abs(around - h) <= LEVEL_TOLERANCE)
    return ok


def snapped(problem: SpatialProblem, x: float, y: float, margin: float, max_shift: float):
    """(x, y) where it is safe and inside the known window, else the safe cell centre nearest it within ``max_shift``
    and inside the window, or None."""
    m = problem.height_map
    x_min, x_max, y_min, y_max = problem.window
    if x_min <= x < x_max and y_min <= y < y_max and safe(m, np.array([x]), np.array([y]), margin)[0]:
        return x, y
    c = m.cell
    n = int(math.ceil(max_shift / c))
    i0 = math.floor((x - m.origin[0]) / c)
    j0 = math.floor((y - m.origin[1]) / c)
    di, dj = np.meshgrid(np.arange(-n, n + 1), np.arange(-n, n + 1))
    cx, cy = m.origin[0] + (i0 + di.ravel() + 0.5) * c, m.origin[1] + (j0 + dj.ravel() + 0.5) * c
    distance = np.hypot(cx - x, cy - y)
    keep = (distance <= max_shift) & (x_min <= cx) & (cx < x_max) & (y_min <= cy) & (cy < y_max)
    keep[keep] = safe(m, cx[keep], cy[keep], margin)
    if not keep.any():
        return None
    k = np.flatnonzero(keep)[np.argmin(distance[keep])]
    return float(cx[k]), float(cy[k])


# long: one hop of the gait after another, each step's placement, snapping and the gait's advance together
def plan_heuristic(problem: SpatialProblem, edge_margin: float, max_shift: float, name: str) -> Plan:
    """The heuristic's footholds from ``problem``'s apex until one passes the target (module doc)."""
    offset_table, advance_table = neutral_gait(problem.params.with_friction(1.0))
    gain = turning_gain(problem.params)
    x, y, z, vx, vy = problem.apex
    speed = math.hypot(vx, vy)
    heading = math.atan2(vy, vx)
    tx, ty = problem.target
    reach = problem.reach
    footholds, before = [], (x, y)   # before: where the next hop's way starts (the body, then each foothold)
    m = problem.height_map
    for _ in range(MAX_HOPS):
        wanted = math.atan2(ty - y, tx - x)
        turn = max(-MAX_TURN, min(MAX_TURN, math.remainder(wanted - heading, 2 * math.pi)))
        below = m.solid[m.index(x, y)]
        ahead = interpolate(offset_table, speed, z - below)
        ux, uy = math.cos(heading), math.sin(heading)
        side = speed * math.sin(turn) / gain   # sideways of the neutral point: turns the velocity by ``turn``
        fx, fy = x + ahead * ux - side * uy, y + ahead * uy + side * ux
        if not math.isfinite(fx):
            return Plan(name, False, problem.target_x, target_y=ty,
                        message=f"no plan found: no gait at {speed:.2f} m/s from {z:.2f} m")
        spot = snapped(problem, fx, fy, edge_margin, max_shift)
        if spot is None:
            outside = not (problem.window[0] <= fx < problem.window[1] and problem.window[2] <= fy < problem.window[3])
            if footholds and outside and problem.target != problem.goal:
                break   # the gait runs out of the perception window before a target on the way: up to its edge
            why = (f"the gait leaves the window at ({fx:.2f}, {fy:.2f}) without reaching the goal" if outside else
                   f"no safe foothold within {max_shift:g} m of ({fx:.2f}, {fy:.2f})")
            return Plan(name, False, problem.target_x, target_y=ty, message=f"no plan found: {why}")
        fz = float(m.height_at(*spot))
        footholds.append((spot[0], spot[1], fz))
        heading += turn
        # the body passes over the foothold and goes on along the new heading: the next apex is the gait's advance
        # less the foothold's lead on it, past the foothold
        beyond = interpolate(advance_table, speed, z - fz) - ahead
        x, y = spot[0] + beyond * math.cos(heading), spot[1] + beyond * math.sin(heading)
        if reaches(before[0], before[1], spot[0], spot[1], reach):
            break
        before = spot
    else:
        return Plan(name, False, problem.target_x, target_y=ty,
                    message=f"no plan found: the gait goes in circles ({MAX_HOPS} hops without reaching the target)")
    n = len(footholds)   # the controller picks the angles when the plan is flown; the gait only guesses the apexes
    seq = FootstepSequence(np.array(footholds).reshape(-1, 3), np.full((n, 2), np.nan), np.full((n, 5), np.nan))
    return Plan(name, True, problem.target_x, sequences=[seq], target_y=ty)
