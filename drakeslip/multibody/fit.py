"""The SLIP template fitted to the multibody robot: the spring-mass parameters whose apex-to-apex map best
predicts the robot's, over hops like the suites' (``examples/fit_template.py`` records them from closed-loop runs).

A hop is (apex, foothold, foothold height) -> next apex. The template predicts it by aiming its leg so that its
foot lands where the robot's did (the SLIP's touchdown geometry with the template's leg length) and stepping its
map (``drakeslip.stepmap``); heights are taken relative to the foothold, where the stance happens. ``fit``
searches the leg length and the stiffness (the map depends on stiffness over mass only, so the mass stays the
robot body's) by Nelder-Mead on the squared x and z errors, ``errors`` reports the per-hop errors and
``by_speed_change`` their summary by how much the hop changed the robot's speed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from drakeslip.multibody.controller import HeldLeg, touchdown_angle
from drakeslip.params import SlipParams
from drakeslip.state import ApexState
from drakeslip.terrain import Terrain
from drakeslip.units import units_of

FIT_NAME = "multibody"   # the fitted template's hopper name
TEMPLATE_FILE = Path(__file__).resolve().parent / "template.json"   # where examples/fit_template.py writes it
# [m/s] the speed changes per hop the errors are also reported between: a hop that brakes hard lands its leg far
# ahead, where the next apex changes steeply with the stance, and the robot strays from the template most there
SPEED_CHANGE_EDGES = (-1.0, 0.0, 1.0)


@dataclass(frozen=True)
class Hop:
    """One robot hop: from ``apex`` (x, z, xdot) it touched down at ``foothold`` (ground ``height``) and reached
    ``next_apex``; ``previous``, the robot's hop before it (None at the start of a run), whose effects the robot
    carries into this one (``drakeslip.apex_correction``)."""

    apex: tuple
    foothold: float
    height: float
    next_apex: tuple
    previous: "Hop | None" = None


def hops_from_log(log, start: ApexState, terrain: Terrain) -> list[Hop]:
    """The completed hops of a ``HopLog`` that started at ``start``."""
    apexes = [tuple(start)] + [tuple(a) for a in log.apexes]
    return [Hop(apexes[k], float(f), float(terrain.height_at(f)), apexes[k + 1])
            for k, f in enumerate(log.footholds[:len(apexes) - 1])]


def predict(hops: list[Hop], params: SlipParams) -> np.ndarray:
    """(n, 3) the template's next apex for each hop (NaN rows where its hop fails)."""
    from drakeslip.stepmap import step_batch

    rows = np.array([(h.apex[0], h.apex[1] - h.height, h.apex[2]) for h in hops], dtype=np.float64).reshape(-1, 3)
    point_foot = HeldLeg(params.leg_length, 0.0, params.gravity)   # the template's leg
    angles = np.array([touchdown_angle(x, z, xd, 0.0, h.foothold, 0.0, point_foot)
                       for (x, z, xd), h in zip(rows, hops)])
    ok = rows[:, 1] > params.leg_length * np.cos(angles) + 1e-3
    out = np.full((len(hops), 3), np.nan)
    if ok.any():
        r = step_batch(rows[ok], angles[ok], Terrain.flat(0.0, length=60.0, x0=-10.0), params)
        nxt = np.column_stack([r.next_x, r.next_z, r.next_xdot])
        nxt[~np.asarray(r.ok)] = np.nan
        out[ok] = nxt
    out[:, 1] += np.array([h.height for h in hops])
    return out


def errors(hops: list[Hop], params: SlipParams) -> np.ndarray:
    """(n, 3) |predicted - robot| next apex, per hop (x [m], z [m], xdot [m/s]); NaN where the template fails."""
    return np.abs(predict(hops, params) - np.array([h.next_apex for h in hops], dtype=np.float64).reshape(-1, 3))


def summary(err: np.ndarray) -> dict:
    """Median and 90th percentile of each error column, and the share of hops the template fails."""
    ok = np.all(np.isfinite(err), axis=1)
    e = err[ok] if ok.any() else np.full((1, 3), np.nan)
    return {"hops": int(len(err)), "template_failed": int((~ok).sum()),
            **{f"{stat}_{name}": float(fn(e[:, i])) for i, name in enumerate(("x", "z", "xdot"))
               for stat, fn in (("median", np.median), ("p90", lambda v: np.percentile(v, 90)))}}


def by_speed_change(hops: list[Hop], err: np.ndarray, edges=SPEED_CHANGE_EDGES) -> list[dict]:
    """``summary`` of the per-hop errors ``err`` over the hops in each band of the robot's speed change (the next
    apex's xdot minus the apex's [m/s]): below ``edges[0]``, between consecutive edges, from the last up; each with
    its "band" [low, high] (None: unbounded). Bands without hops are left out."""
    change = np.array([h.next_apex[2] - h.apex[2] for h in hops])
    bounds = (-math.inf, *edges, math.inf)
    bands = []
    for low, high in zip(bounds, bounds[1:]):
        inside = (change >= low) & (change < high)
        if inside.any():
            bands.append({"band": [low if math.isfinite(low) else None, high if math.isfinite(high) else None],
                          **summary(err[inside])})
    return bands


def fit(hops: list, start: SlipParams, position_errors=None) -> SlipParams:
    """The leg length and stiffness (from ``start``) minimizing the summed squared position errors over ``hops``
    (``position_errors(hops, params)``: (n, k) errors, NaN where the template fails; default the x and z of
    ``errors``; a failed template hop costs as much as a 0.5 m error)."""
    from scipy.optimize import minimize

    position_errors = position_errors or (lambda h, p: errors(h, p)[:, :2])
    length = units_of(start).length   # the paper's hopper's lengths below, in ``start``'s

    def cost(v):
        leg, log_k = v
        if not start.min_leg_length + 0.05 * length < leg < 1.5 * start.leg_length:
            return 1e6
        p = replace(start, leg_length=float(leg), stiffness=float(math.exp(log_k)))
        err = position_errors(hops, p)
        return float(np.sum(np.where(np.isfinite(err), err, 0.5 * length) ** 2))

    best = minimize(cost, [start.leg_length, math.log(start.stiffness)], method="Nelder-Mead",
                    options={"xatol": 1e-4 * length, "fatol": 1e-6, "maxiter": 200})
    leg, log_k = best.x
    return replace(start, leg_length=float(leg), stiffness=float(math.exp(log_k)))


def fitted_template() -> SlipParams | None:
    """The template fitted to the default robot (``TEMPLATE_FILE``), None when no fit has been written."""
    from drakeslip.hopper_file import load_hopper

    return load_hopper(TEMPLATE_FILE).params if TEMPLATE_FILE.is_file() else None


def template_for(hopper: SlipParams, template: SlipParams) -> SlipParams:
    """The template the planners plan for on the robot of ``hopper`` (``RobotParams.for_hopper``), from ``template``,
    one fitted to the paper's hopper's robot (``TEMPLATE_FILE``), with ``hopper``'s friction: for the paper's hopper
    ``template`` itself; for another, ``hopper`` with the fit's leg length and stiffness as factors of the paper's.
    Every value of a hopper's robot is the paper's robot's in the hopper's units, so the factors are exact for a
    hopper of the paper's dimensionless stiffness and friction (Froude similarity) and an estimate otherwise. A
    template with a learned correction (``drakeslip.params.RobotTemplate``, ``examples/fit_correction.py``) is
    trained on one robot's hops in its units: it is taken as it is for the hopper whose robot that is (its SLIP is
    the template ``fitted_template`` makes that robot's), and ValueError for another."""
    paper = SlipParams()
    if type(template) is not SlipParams:
        fitted = template_for(hopper, fitted_template()) if TEMPLATE_FILE.is_file() else None
        if fitted is None or replace(template.slip, friction=hopper.friction) != fitted:
            raise ValueError(f"the template's learned correction was trained on another hopper's robot than the "
                             f"robot of this {hopper.mass:g} kg, {hopper.leg_length:g} m hopper (examples/"
                             f"fit_correction.py --hopper trains one for it)")
        return template.with_friction(hopper.friction)
    if hopper.with_friction(paper.friction) == paper:
        return template.with_friction(hopper.friction)
    return replace(hopper, leg_length=hopper.leg_length * template.leg_length / paper.leg_length,
                   stiffness=hopper.stiffness * template.stiffness / paper.stiffness)
