"""Plans as self-contained JSON files (``"format": "drakeslip-plan/2"``), so a plan can be checked, replayed or
stress-tested later without the planner, the suite or the random terrain generator that produced it.

A file holds everything the plan's execution depends on: the initial apex, the whole terrain (cell heights,
not a generator seed, so a change to a generator cannot silently change a stored plan), the hopper (its
parameters, with the ground's friction, and ``"hopper"``, the record ``NamedHopper.to_record`` of the hopper the plan
was made for: its name, parameters and hopper file's digest), the goal, and the plan itself: footholds, leg angles
and predicted apexes, and ``target_x``, the x its last foothold reaches by the plan's own account: the planner's
target when the footholds pass it, else the last foothold (a plan that stops where the robot's view ends, or plans
one step ahead). A planner that does not predict angles or apexes (``lstm`` gives only the first angle) leaves NaN
there, stored as ``null``.

A file whose fields disagree with each other, or hold a value outside its physical bound (``drakeslip.bounds``),
is malformed (ValueError naming the field): lengths that differ, a foothold two leg reaches or more behind the one
before it (2 L0 sin(atan mu): the body moves forward, but a slow gait may step back by less), predicted apexes
whose x does not increase, a start or predicted apex not above the terrain, a start inside a ditch, a leg angle
outside (-pi/2, pi/2), a predicted apex given in part. A ``"hopper"`` record whose body (every parameter but the
friction) is not ``params``' is malformed too. Version 1 files are read too (their ``target_x`` is the planner's
target), as are files without a hopper record (their hopper is ``params``').
"""
from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass

import numpy as np

from drakeslip import ApexState, SlipParams, Terrain
from drakeslip.hopper_file import NamedHopper, check_same_hopper, hopper_for, hopper_from_record
from drakeslip.jobs.files import atomic_write, read_json
from drakeslip.bounds import CELL, POSITION, TERRAIN_START
from drakeslip.params import check_number, params_from_record
from drakeslip.state import APEX_BOUNDS, as_apex, check_start
from drakeslip.terrain import DITCH_HEIGHT, family

from planners.base import Plan
from planners.formats.suite import read_apex, required_field

PLAN_FORMAT = "drakeslip-plan/2"
READ_FORMATS = ("drakeslip-plan/1", PLAN_FORMAT)


@dataclass(frozen=True)
class PlanRecord:
    """One plan with its problem. ``leg_angles`` (N,) and ``apexes`` (N, 3) may hold NaN where the planner
    made no prediction; ``footholds`` (N,) are always finite. ``hopper``: the hopper the plan was made for (None:
    the one ``params`` describes)."""

    planner: str
    apex: ApexState
    terrain: Terrain
    params: SlipParams
    goal_x: float
    target_x: float
    footholds: np.ndarray
    leg_angles: np.ndarray
    apexes: np.ndarray
    hopper: NamedHopper | None = None

    def __post_init__(self):
        if self.hopper is not None:
            check_same_hopper(self.hopper, self.params, "the plan's params")
        n = self.footholds.shape
        if len(n) != 1 or n[0] == 0 or not np.all(np.isfinite(self.footholds)):
            raise ValueError(f"a plan needs a non-empty list of finite footholds, got {self.footholds!r}")
        if self.leg_angles.shape != n or self.apexes.shape != (n[0], 3):
            raise ValueError(f"{n[0]} footholds need {n[0]} leg angles and {n[0]} apexes, got shapes "
                             f"{self.leg_angles.shape} and {self.apexes.shape}")
        # The body moves forward, and in stance the foot is at most L0 sin(atan mu) from it (inside the friction
        # cone), so a foothold lies less than two such reaches behind the one before (a slow gait can step back).
        reach = 2.0 * self.params.leg_length * self.params.friction / math.hypot(1.0, self.params.friction)
        back = np.flatnonzero(np.diff(self.footholds) <= -reach)
        if back.size:
            i = int(back[0]) + 1
            raise ValueError(f"footholds[{i}] = {self.footholds[i]:g} is "
                             f"{self.footholds[i - 1] - self.footholds[i]:g} m behind footholds[{i - 1}] = "
                             f"{self.footholds[i - 1]:g}: a hopper moving forward steps back by less than two leg "
                             f"reaches (2 L0 sin(atan mu) = {reach:.3g} m)")
        ahead = np.flatnonzero(np.diff(self.apexes[:, 0]) <= 0)   # NaN rows (no prediction) compare False
        if ahead.size:
            i = int(ahead[0]) + 1
            raise ValueError(f"apexes[{i}] x = {self.apexes[i, 0]:g} is not past apexes[{i - 1}] x = "
                             f"{self.apexes[i - 1, 0]:g}: the body moves forward")
        check_start(self.apex, self.terrain, self.params)
        rim = self.terrain.far_rim(self.apex.x)
        if rim is not None and self.apex.z <= rim[1]:
            raise ValueError(f"the start apex (x={self.apex.x:g}, z={self.apex.z:g}) is inside a ditch")
        bad = np.flatnonzero(np.isfinite(self.leg_angles) & ~(np.abs(self.leg_angles) < math.pi / 2))
        if bad.size:
            raise ValueError(f"leg_angles[{bad[0]}] = {self.leg_angles[bad[0]]:g} is outside (-pi/2, pi/2)")
        given = np.isfinite(self.apexes)
        partial = np.flatnonzero(given.any(axis=1) & ~given.all(axis=1))
        if partial.size:
            raise ValueError(f"apexes[{partial[0]}] is given in part: {self.apexes[partial[0]].tolist()}")
        for i in np.flatnonzero(given.all(axis=1)):
            x, z, _ = self.apexes[i]
            if z <= self.terrain.height_at(x):
                raise ValueError(f"apexes[{i}] = ({x:g}, {z:g}) is not above the terrain")

    @classmethod
    def from_plan(cls, plan: Plan, apex, terrain, goal_x: float, params: SlipParams,
                  hopper: NamedHopper | None = None) -> "PlanRecord":
        """``terrain`` is a Terrain, its ``to_dict()`` form, or a generator spec ``{"family", "seed"}``. Pass the
        whole terrain, not the perception window the planner saw, so the check covers the real ground. ``hopper``
        (default: ``hopper_for(params)``, the paper's or one named 'custom') is recorded with the plan."""
        if not plan.success:
            raise ValueError(f"planner {plan.planner!r} found no plan to save: {plan.message}")
        reaches = min(float(plan.target_x), float(plan.footholds[-1]))
        return cls(plan.planner, as_apex(apex), _terrain(terrain), params,
                   float(goal_x), reaches, np.array(plan.footholds, dtype=float),
                   np.array(plan.leg_angles, dtype=float), np.array(plan.apexes, dtype=float).reshape(-1, 3),
                   hopper or hopper_for(params))

    def to_dict(self) -> dict:
        return {"format": PLAN_FORMAT, "planner": self.planner, "apex": self.apex._asdict(),
                "terrain": {**self.terrain.to_dict(), "ditch_height": self.terrain.ditch_height},
                "params": asdict(self.params), "goal_x": self.goal_x, "target_x": self.target_x,
                "footholds": self.footholds.tolist(), "leg_angles": nulls(self.leg_angles),
                "apexes": nulls(self.apexes),
                **({"hopper": self.hopper.to_record()} if self.hopper is not None else {})}

    @classmethod
    def from_dict(cls, d, source: str = "plan") -> "PlanRecord":
        """Check every field; a bad one raises ValueError naming ``source`` and the field (e.g. footholds[2])."""
        planner = read_planner(d, source, READ_FORMATS)
        t = required_field(d, "terrain", source)
        where = f"{source}: terrain"
        heights = required_field(t, "heights", where)
        if not isinstance(heights, list) or not heights:
            raise ValueError(f"{where}.heights must be a non-empty list of numbers")
        terrain = Terrain([check_number(h, f"{where}.heights[{j}]", bound=POSITION) for j, h in enumerate(heights)],
                          cell=check_number(required_field(t, "cell", where), f"{where}.cell", bound=CELL),
                          x0=check_number(required_field(t, "x0", where), f"{where}.x0", bound=TERRAIN_START),
                          ditch_height=check_number(required_field(t, "ditch_height", where), f"{where}.ditch_height",
                                                    bound=POSITION))
        apex = read_apex(required_field(d, "apex", source), f"{source}: apex")
        if apex.z <= terrain.height_at(apex.x):
            raise ValueError(f"{source}: apex.z={apex.z} is not above the terrain at x={apex.x}")
        params = read_params(d, source)
        footholds = [check_number(v, f"{source}: footholds[{i}]", bound=POSITION)
                     for i, v in enumerate(_list(d, "footholds", source))]
        n = len(footholds)
        angles = [_optional(v, f"{source}: leg_angles[{i}]") for i, v in enumerate(_list(d, "leg_angles", source, n))]
        apexes = []
        for i, row in enumerate(_list(d, "apexes", source, n)):
            if not isinstance(row, list) or len(row) != 3:
                raise ValueError(f"{source}: apexes[{i}] must be [x, z, xdot], got {row!r}")
            apexes.append([_optional(v, f"{source}: apexes[{i}][{j}]", bound)
                           for j, (v, bound) in enumerate(zip(row, APEX_BOUNDS))])
        goal_x = check_number(required_field(d, "goal_x", source), f"{source}: goal_x", bound=POSITION)
        target_x = check_number(required_field(d, "target_x", source), f"{source}: target_x", bound=POSITION)
        hopper = hopper_from_record(d["hopper"], f"{source}: hopper") if "hopper" in d else None
        try:
            return cls(planner, apex, terrain, params, goal_x, target_x, np.array(footholds), np.array(angles),
                       np.array(apexes).reshape(n, 3), hopper)
        except ValueError as exc:
            raise ValueError(f"{source}: {exc}") from exc

    def save(self, path) -> None:
        """Write atomically (temporary file, then rename); strict JSON: NaN is written as null."""
        with atomic_write(path, "w") as f:
            json.dump(self.to_dict(), f, indent=1, allow_nan=False)


def save_plan(path, plan: Plan, apex, terrain, goal_x: float, params: SlipParams,
              hopper: NamedHopper | None = None) -> PlanRecord:
    """Write ``plan`` (a planner's result for this apex, terrain, goal and parameters, made for ``hopper``: see
    ``PlanRecord.from_plan``) to ``path``."""
    record = PlanRecord.from_plan(plan, apex, terrain, goal_x, params, hopper)
    record.save(path)
    return record


def load_plan(path) -> PlanRecord:
    """Read a plan file; a malformed one raises ValueError naming the file and the bad field."""
    return PlanRecord.from_dict(read_json(path, "plan file"), source=f"plan file {path}")


def _terrain(spec) -> Terrain:
    if isinstance(spec, Terrain):
        return spec
    if isinstance(spec, dict) and "family" in spec:
        generate, seed = family(spec["family"]), required_field(spec, "seed", "terrain spec")
        return generate(int(seed))
    if isinstance(spec, dict):
        x0, cell, heights = (required_field(spec, key, "terrain") for key in ("x0", "cell", "heights"))
        return Terrain(heights, cell, x0, spec.get("ditch_height", DITCH_HEIGHT))
    raise TypeError(f"terrain must be a Terrain, its to_dict() form or {{'family', 'seed'}}, got {spec!r}")


def nulls(values: np.ndarray) -> list:
    """NaN -> None, element-wise on nested lists (JSON has no NaN)."""
    return [nulls(v) if isinstance(v, np.ndarray) else (None if math.isnan(v) else float(v)) for v in values]


def read_planner(d, source: str, formats: tuple) -> str:
    """The planner named by a plan document whose format is one of ``formats``; ValueError naming the field
    otherwise."""
    fmt = required_field(d, "format", source)
    if fmt not in formats:
        wanted = f"one of {formats}" if len(formats) > 1 else repr(formats[0])
        raise ValueError(f"{source}: format must be {wanted}, got {fmt!r}")
    planner = required_field(d, "planner", source)
    if not isinstance(planner, str):
        raise ValueError(f"{source}: planner must be a string, got {planner!r}")
    return planner


def read_params(d, source: str) -> SlipParams:
    """A plan document's ``params`` (the hopper with the ground's friction); ValueError naming the field otherwise."""
    p = required_field(d, "params", source)
    if not isinstance(p, dict):
        raise ValueError(f"{source}: params must be an object, got {type(p).__name__}")
    try:
        return params_from_record(p)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{source}: params: {exc}") from exc


def _optional(value, where: str, bound=None) -> float:
    """A number inside ``bound`` or null (NaN: the planner made no prediction)."""
    return math.nan if value is None else check_number(value, where, bound=bound)


def _list(d, key: str, source: str, length: int | None = None) -> list:
    value = required_field(d, key, source)
    if not isinstance(value, list) or not value or (length is not None and len(value) != length):
        size = "a non-empty list" if length is None else f"a list of {length} entries (one per foothold)"
        raise ValueError(f"{source}: {key} must be {size}, got {value!r:.80}")
    return value
