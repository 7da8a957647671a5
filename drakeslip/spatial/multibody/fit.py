"""The spatial SLIP template fitted to the spatial robot: the spring-mass parameters whose apex-to-apex map best
predicts the robot's, over hops like the map suites' (``examples/fit_template.py --robot spatial`` records them from
the robot's map loop and writes the fit).

A hop is (apex (x, y, z, xdot, ydot), foothold (x, y, ground height)) -> next apex. The template predicts it by aiming
its leg so that its foot lands on the foothold (the spatial controller's aim, ``drakeslip.spatial.controller``) and
stepping its map (``drakeslip.spatial.stepmap``) on level ground at the foothold's height: the stance happens there,
and a flight over other ground is the map's, not the robot's. The fit searches the leg length and the stiffness as
the planar robot's does (``drakeslip.multibody.fit.fit``). The fit is stored as the factors of the hopper's own leg
length and stiffness, so that it holds for the robot of any hopper (``SpatialRobotParams.for_hopper`` scales one robot
to every hopper's units, and these factors are dimensionless).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from drakeslip.params import SlipParams

FIT_FILE = Path(__file__).resolve().parent / "template.json"   # where examples/fit_template.py writes the fit
FIT_FORMAT = "drakeslip-spatial-template/1"
ERROR_NAMES = ("x", "y", "z", "position", "speed")   # the columns of ``errors``


@dataclass(frozen=True)
class SpatialHop:
    """One robot hop: from ``apex`` (x, y, z, xdot, ydot), aimed at ``foothold`` (x, y, z: the ground's height there),
    it reached ``next_apex``."""

    apex: tuple
    foothold: tuple
    next_apex: tuple


def hops_from_plans(plans: list) -> list[SpatialHop]:
    """The hops of a map loop's planning records (``planners.spatial_loop.MapLoop.plans``) where each record flew one
    foothold from its apex and the next record was made at the apex that hop reached (a loop flying one foothold a
    plan, ``executed_per_plan`` 1)."""
    return [SpatialHop(tuple(a["apex"]), tuple(a["executed"][0]), tuple(b["apex"]))
            for a, b in zip(plans, plans[1:]) if len(a["executed"]) == 1]


def predict(hops: list[SpatialHop], params: SlipParams) -> np.ndarray:
    """(n, 5) the template's next apex for each hop (NaN rows where its hop fails or cannot reach the foothold)."""
    from drakeslip.spatial.controller import aim_many
    from drakeslip.spatial.heightmap import HeightMap
    from drakeslip.spatial.stepmap import step_batch3d

    out = np.full((len(hops), 5), np.nan)
    if not hops:
        return out
    feet = np.array([h.foothold for h in hops], dtype=np.float64)
    rows = np.array([h.apex for h in hops], dtype=np.float64) - np.column_stack([feet, np.zeros((len(hops), 2))])
    aimed = aim_many(rows, np.zeros((len(hops), 3)), params.as_array())
    ok = np.isfinite(aimed[:, 2]) & (aimed[:, 2] < 1e-3 * params.leg_length)
    if ok.any():
        span = 4.0 * params.leg_length + np.abs(rows[ok, :2]).max()
        level = HeightMap.flat(0.0, 0.05 * params.leg_length, (-span, -span), (2 * span, 2 * span))
        result = step_batch3d(rows[ok], aimed[ok, :2], level, params)
        nxt = np.array(result.end_state[:, :5], dtype=np.float64)
        nxt[~np.asarray(result.ok)] = np.nan
        out[ok] = nxt + np.column_stack([feet[ok], np.zeros((int(ok.sum()), 2))])
    return out


def errors(hops: list[SpatialHop], params: SlipParams) -> np.ndarray:
    """(n, 5) per hop: |predicted - robot| next apex in x, y, z [m], the position's distance [m] and the horizontal
    velocity's [m/s] (``ERROR_NAMES``); NaN where the template fails."""
    robot = np.array([h.next_apex for h in hops], dtype=np.float64).reshape(-1, 5)
    d = predict(hops, params) - robot
    return np.column_stack([np.abs(d[:, :3]), np.linalg.norm(d[:, :3], axis=1), np.linalg.norm(d[:, 3:], axis=1)])


def position_errors(hops: list[SpatialHop], params: SlipParams) -> np.ndarray:
    """(n, 3) the x, y and z errors of ``errors``: what the fit minimizes."""
    return errors(hops, params)[:, :3]


def summary(err: np.ndarray) -> dict:
    """Median and 90th percentile of each column of ``errors``, and the share of hops the template fails."""
    ok = np.all(np.isfinite(err), axis=1)
    e = err[ok] if ok.any() else np.full((1, len(ERROR_NAMES)), np.nan)
    return {"hops": int(len(err)), "template_failed": int((~ok).sum()),
            **{f"{stat}_{name}": float(fn(e[:, i])) for i, name in enumerate(ERROR_NAMES)
               for stat, fn in (("median", np.median), ("p90", lambda v: np.percentile(v, 90)))}}


def fit_factors(hops: list[SpatialHop], hopper: SlipParams) -> dict:
    """{"leg_length", "stiffness"}: the factors of ``hopper``'s leg length and stiffness that fit ``hops`` best."""
    from drakeslip.multibody.fit import fit

    fitted = fit(hops, hopper, position_errors)
    return {"leg_length": fitted.leg_length / hopper.leg_length, "stiffness": fitted.stiffness / hopper.stiffness}


def fitted(hopper: SlipParams, factors: dict) -> SlipParams:
    """``hopper``'s SLIP with the fitted ``factors`` applied."""
    return replace(hopper, leg_length=hopper.leg_length * factors["leg_length"],
                   stiffness=hopper.stiffness * factors["stiffness"])


def save_fit(path, factors: dict, report: dict) -> None:
    """Write the fit's factors with the report that measured them."""
    from drakeslip.jobs.files import atomic_write

    with atomic_write(path, "w") as f:
        json.dump({"format": FIT_FORMAT, "factors": factors, "report": report}, f, indent=1)


def fitted_template(hopper: SlipParams, path=FIT_FILE) -> SlipParams:
    """The template fitted to the spatial robot of ``hopper`` (``fitted`` with the factors in ``path``); ValueError
    naming the file where it is not a fit."""
    refusal = ValueError(f"{path} is not a spatial template fit ({FIT_FORMAT}: examples/fit_template.py --robot "
                         f"spatial writes one)")
    try:
        document = json.loads(Path(path).read_text())
        factors = {name: float(document["factors"][name]) for name in ("leg_length", "stiffness")}
        fmt = document["format"]
    except (OSError, ValueError, KeyError, TypeError):
        raise refusal from None
    if fmt != FIT_FORMAT or not all(math.isfinite(v) and 0 < v < 10 for v in factors.values()):
        raise refusal
    return fitted(hopper, factors)
