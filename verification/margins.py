"""Safety margins of a logged Drake run: how far it stayed from each failure guard.

The margins are taken from the simulator's log: the body state at every integrator step (at most ``max_step`` =
2 ms apart) plus the exact states of the localized touchdown, liftoff and apex events. Between samples an extreme
can be slightly tighter than reported, by at most about half a step's travel (a few mm at 3 m/s) for the
clearances and far less for the others (the touchdown and liftoff states, where the leg leans most, are exact).
The guards themselves come from ``drakeslip.dynamics``, the one definition both backends use.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from drakeslip import dynamics as dyn
from drakeslip.slip_hopper import HybridState, Mode
from drakeslip.simulation import SimulationResult
from drakeslip.terrain import Terrain

MODE, DEPLOYED, ANGLE, FOOT_X, FOOT_Z = (HybridState._fields.index(f)
                                         for f in ("mode", "leg_deployed", "leg_angle", "foot_x", "foot_z"))


class Margin(NamedTuple):
    """The tightest value of one margin over the run (positive = safe), the hop, and the x where it was (the
    body's; for ``edge_distance`` the foothold's)."""

    value: float
    hop: int
    x: float


class Margins(NamedTuple):
    """Every margin of a run (see ``Certificate`` in plan_check.py for their meaning)."""

    friction: Margin
    body_clearance: Margin
    foot_clearance: Margin
    stroke: Margin
    edge_distance: Margin
    edge_distances: list
    max_compression: float
    stroke_length: float


def margins(sim: SimulationResult) -> Margins:
    """The margins of a logged run that ended without a failure."""
    p, terrain, params = sim.params.as_array(), sim.terrain, sim.params
    events = [e for e in sim.events if e.kind in ("touchdown", "liftoff", "apex")]
    apex_times = np.array([e.time for e in sim.events if e.kind == "apex"])
    # Every integrator step's sample, then the exact event states (the foot pinned at touchdown and liftoff).
    t = np.r_[sim.times, [e.time for e in events]]
    s = np.vstack([sim.states] + [np.array([e.state for e in events])])
    h = np.vstack([sim.hybrid] + [event_hybrid(e, sim.hybrid.shape[1]) for e in events])
    hop = np.searchsorted(apex_times, t, side="right")
    x, z = s[:, 0], s[:, 1]

    def tightest(values, mask):
        i = np.flatnonzero(mask)[np.argmin(values[mask])] if mask.any() else None
        return Margin(math.inf, -1, math.nan) if i is None else Margin(float(values[i]), int(hop[i]), float(x[i]))

    stance = h[:, MODE] == int(Mode.STANCE)
    fx, fz = h[:, FOOT_X], h[:, FOOT_Z]
    friction = np.array([dyn.friction_margin(x[i], z[i], fx[i], fz[i], p) / (z[i] - fz[i]) if stance[i] else 0.0
                         for i in range(t.size)])
    stroke = np.array([dyn.stroke_left(x[i], z[i], fx[i], fz[i], p) if stance[i] else 0.0 for i in range(t.size)])
    falling = (h[:, MODE] == int(Mode.FLIGHT)) & (h[:, DEPLOYED] == 1)
    foot = np.array([dyn.foot_position(x[i], z[i], h[i, ANGLE], p) for i in range(t.size)])
    tops, faces = profile(terrain)
    body = np.minimum(distance_to_tops(x, z, tops), distance_to_faces(x, z, faces))
    foot_gap = distance_to_faces(foot[:, 0], foot[:, 1], faces)
    stroke_margin = tightest(stroke, stance)
    edges = faces[0]
    edge_distances = [float(np.min(np.abs(edges - f))) if edges.size else math.inf for f in sim.footholds]
    edge_i = int(np.argmin(edge_distances))
    stroke_length = params.leg_length - params.min_leg_length
    return Margins(friction=tightest(friction, stance), body_clearance=tightest(body, np.ones_like(stance)),
                   foot_clearance=tightest(foot_gap, falling), stroke=stroke_margin,
                   edge_distance=Margin(edge_distances[edge_i], edge_i, float(sim.footholds[edge_i])),
                   edge_distances=edge_distances, max_compression=float(stroke_length - stroke_margin.value),
                   stroke_length=stroke_length)


def event_hybrid(event, width: int) -> np.ndarray:
    """The hybrid row that holds at an event's exact state: stance with the foot pinned at touchdown and
    liftoff, flight with the leg retracted at an apex (its foot is placed by the apex's reset)."""
    row = np.zeros((1, width))
    row[0, MODE] = int(Mode.STANCE) if event.kind in ("touchdown", "liftoff") else int(Mode.FLIGHT)
    row[0, ANGLE] = event.leg_angle
    if event.foot is not None:
        row[0, FOOT_X], row[0, FOOT_Z] = event.foot
    return row


def profile(terrain: Terrain):
    """The terrain as segments: tops (x_from, x_to, height), the first and last extended flat to infinity,
    and vertical faces (x, low, high) wherever the height changes."""
    hs = terrain.heights
    change = np.flatnonzero(np.diff(hs) != 0) + 1
    xe = terrain.x0 + terrain.cell * change
    tops = (np.r_[-math.inf, xe], np.r_[xe, math.inf], hs[np.r_[0, change]])
    faces = (xe, np.minimum(hs[change - 1], hs[change]), np.maximum(hs[change - 1], hs[change]))
    return tops, faces


def distance_to_tops(px, pz, tops) -> np.ndarray:
    a, b, height = (v[None, :] for v in tops)
    dx = np.maximum(np.maximum(a - px[:, None], 0.0), px[:, None] - b)
    return np.min(np.hypot(dx, pz[:, None] - height), axis=1)


def distance_to_faces(px, pz, faces) -> np.ndarray:
    if faces[0].size == 0:
        return np.full(px.shape, math.inf)
    xe, low, high = (v[None, :] for v in faces)
    dz = np.maximum(np.maximum(low - pz[:, None], 0.0), pz[:, None] - high)
    return np.min(np.hypot(px[:, None] - xe, dz), axis=1)
