"""Plans on a height map as self-contained JSON files (``"format": "drakeslip-map-plan/1"``): the planar plan file
(``planners.formats.plan``) for the spatial hopper, so a map plan can be checked, replayed or stress-tested later
without the planner or the suite that produced it.

A file holds the start apex {"x", "y", "z", "xdot", "ydot"}, the map as a map suite records it
(``planners.formats.map_suite``: a drawn map's family, seed, difficulty and length, or a map file's path relative to
the plan file, each with the SHA-256 of its cells, checked on load, so a changed generator or file cannot silently
change a stored plan), the hopper (``params`` with the ground's friction, and ``"hopper"``, ``NamedHopper.to_record``),
the goal and the target {"x", "y"} (the plan's target: the goal, or the point short of it where the window the
planner saw ends), and the plan: footholds [x, y, z] (the contact point on the map), leg angles [pitch, roll] and
predicted apexes [x, y, z, xdot, ydot], null where the planner made no prediction.

A file whose fields disagree with each other or with the map is malformed (ValueError naming the field): lengths
that differ, a foothold over a hole or off the map's height there by more than a millimetre (a plan made on another
map), a start that ``check_map_start`` refuses, a leg angle outside (-pi/2, pi/2), a predicted apex given in part or
not above the map, a ``"hopper"`` whose body is not ``params``'.
"""
from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from drakeslip.bounds import POSITION, SPEED
from drakeslip.hopper_file import NamedHopper, check_same_hopper, hopper_from_record
from drakeslip.jobs.files import atomic_write, read_json
from drakeslip.params import SlipParams, check_number
from drakeslip.spatial.heightmap import HeightMap
from drakeslip.units import units_of

from planners.base import Plan
from planners.core.spatial_tree import SpatialTarget
from planners.formats.map_suite import APEX_FIELDS, check_map_start, map_record, read_apex3d, read_map, read_point
from planners.formats.plan import nulls, read_params, read_planner
from planners.formats.suite import required_field
from planners.search.spatial_problem import GOAL_RADIUS, WINDOW_ASIDE, goal_reach

MAP_PLAN_FORMAT = "drakeslip-map-plan/1"
MAP_PLAN_FAMILY = "drakeslip-map-plan/"
FOOTHOLD_HEIGHT = 1e-3   # [m] a foothold's z may differ this much from the map's height under it (paper's lengths)


@dataclass(frozen=True)
class MapPlanRecord:
    """One plan on a height map with its problem (module doc). ``footholds`` (N, 3) are finite; ``leg_angles``
    (N, 2) and ``apexes`` (N, 5) hold NaN where the planner made no prediction. ``source``: the map's record as a
    map suite holds it, a file's path absolute."""

    planner: str
    apex: tuple
    height_map: HeightMap
    source: dict
    params: SlipParams
    goal: tuple
    target: tuple
    footholds: np.ndarray
    leg_angles: np.ndarray
    apexes: np.ndarray
    hopper: NamedHopper

    def __post_init__(self):
        check_same_hopper(self.hopper, self.params, "the plan's params")
        n = len(self.footholds)
        if self.footholds.shape != (n, 3) or n == 0 or not np.all(np.isfinite(self.footholds)):
            raise ValueError(f"a map plan needs a non-empty list of finite footholds [x, y, z], got shape "
                             f"{self.footholds.shape}")
        if self.leg_angles.shape != (n, 2) or self.apexes.shape != (n, 5):
            raise ValueError(f"{n} footholds need {n} leg angles [pitch, roll] and {n} apexes, got shapes "
                             f"{self.leg_angles.shape} and {self.apexes.shape}")
        check_map_start(self.apex, self.height_map, self.params, "the start apex")
        slack = FOOTHOLD_HEIGHT * units_of(self.params).length
        for i, (x, y, z) in enumerate(self.footholds):
            ground = self.height_map.height_at(x, y)
            if math.isnan(ground):
                raise ValueError(f"footholds[{i}] ({x:g}, {y:g}) is over a hole of the map")
            if abs(z - ground) > slack:
                raise ValueError(f"footholds[{i}].z = {z:g} m is not the map's height {ground:g} m at ({x:g}, {y:g}): "
                                 "a plan made on another map")
        bad = np.argwhere(np.isfinite(self.leg_angles) & ~(np.abs(self.leg_angles) < math.pi / 2))
        if bad.size:
            i, j = bad[0]
            raise ValueError(f"leg_angles[{i}][{j}] = {self.leg_angles[i, j]:g} is outside (-pi/2, pi/2)")
        given = np.isfinite(self.apexes)
        partial = np.flatnonzero(given.any(axis=1) & ~given.all(axis=1))
        if partial.size:
            raise ValueError(f"apexes[{partial[0]}] is given in part: {self.apexes[partial[0]].tolist()}")
        for i in np.flatnonzero(given.all(axis=1)):
            x, y, z = self.apexes[i, :3]
            ground = self.height_map.height_at(x, y)
            if not math.isnan(ground) and z <= ground:
                raise ValueError(f"apexes[{i}] = ({x:g}, {y:g}, {z:g}) is not above the map ({ground:g} m there)")

    @property
    def reach(self) -> SpatialTarget:
        """What the plan's last hop must reach (``planners.search.spatial_problem``): within the goal radius of the
        goal when the target is the goal, else past the target's line across the way from the start to the goal."""
        units = units_of(self.params)
        if math.dist(self.target, self.goal) <= 1e-9 * units.length:
            return goal_reach(self.goal, GOAL_RADIUS * units.length)
        dx, dy = self.goal[0] - self.apex[0], self.goal[1] - self.apex[1]
        norm = math.hypot(dx, dy)
        return SpatialTarget(float(self.target[0]), float(self.target[1]), dx / norm, dy / norm,
                             WINDOW_ASIDE * units.length, 0.0)

    # many parameters: the problem the plan was made for, each a field of the file
    @classmethod
    def from_plan(cls, plan: Plan, apex, height_map: HeightMap, source: dict, goal, params: SlipParams,
                  hopper: NamedHopper) -> "MapPlanRecord":
        """The record of a plan found on ``height_map`` (the whole map, not the window the planner saw, so a check
        covers the real ground), whose record a map suite holds as ``source``."""
        if not plan.success:
            raise ValueError(f"planner {plan.planner!r} found no plan to save: {plan.message}")
        return cls(plan.planner, tuple(float(v) for v in apex), height_map, dict(source), params,
                   tuple(float(g) for g in goal), (float(plan.target_x), float(plan.target_y)),
                   np.array(plan.footholds, dtype=float).reshape(-1, 3),
                   np.array(plan.leg_angles, dtype=float).reshape(-1, 2),
                   np.array(plan.apexes, dtype=float).reshape(-1, 5), hopper)

    def to_dict(self, folder=None) -> dict:
        """The file's document; a map file's path relative to ``folder`` (where the document is written)."""
        return {"format": MAP_PLAN_FORMAT, "planner": self.planner, "apex": dict(zip(APEX_FIELDS, self.apex)),
                "map": map_record(self.source, folder), "params": asdict(self.params),
                "hopper": self.hopper.to_record(), "goal": {"x": self.goal[0], "y": self.goal[1]},
                "target": {"x": self.target[0], "y": self.target[1]}, "footholds": self.footholds.tolist(),
                "leg_angles": nulls(self.leg_angles), "apexes": nulls(self.apexes)}

    @classmethod
    def from_dict(cls, d, source: str = "map plan", folder=None) -> "MapPlanRecord":
        """Check every field; a bad one raises ValueError naming ``source`` and the field (e.g. footholds[2][1]).
        A map file is read relative to ``folder`` (default: the working directory)."""
        planner = read_planner(d, source, (MAP_PLAN_FORMAT,))
        folder = Path.cwd() if folder is None else Path(folder)
        height_map, map_source = read_map(required_field(d, "map", source), f"{source}: map", folder, {})
        params = read_params(d, source)
        hopper = hopper_from_record(required_field(d, "hopper", source), f"{source}: hopper")
        rows = {name: read_rows(d, name, width, source, bounds)
                for name, width, bounds in (("footholds", 3, (POSITION,) * 3), ("leg_angles", 2, (None, None)),
                                            ("apexes", 5, (POSITION,) * 3 + (SPEED,) * 2))}
        apex = read_apex3d(required_field(d, "apex", source), f"{source}: apex")
        goal, target = (read_point(required_field(d, name, source), f"{source}: {name}") for name in ("goal", "target"))
        try:   # the record's own checks (``__post_init__``), which do not know the source
            return cls(planner, apex, height_map, map_source, params, goal, target, rows["footholds"],
                       rows["leg_angles"], rows["apexes"], hopper)
        except ValueError as exc:
            raise ValueError(f"{source}: {exc}") from exc

    def save(self, path) -> None:
        """Write atomically (temporary file, then rename); strict JSON: NaN is written as null."""
        with atomic_write(path, "w") as f:
            json.dump(self.to_dict(Path(path).resolve().parent), f, indent=1, allow_nan=False)


def read_rows(d: dict, name: str, width: int, source: str, bounds) -> np.ndarray:
    """The list ``name`` of rows of ``width`` numbers (null for NaN, except in footholds) as an (N, width) array,
    each number inside its bound (None: any finite); ValueError naming the entry otherwise."""
    rows = required_field(d, name, source)
    if not isinstance(rows, list) or not rows:
        raise ValueError(f"{source}: {name} must be a non-empty list of rows of {width} numbers")
    out = np.full((len(rows), width), np.nan)
    for i, row in enumerate(rows):
        if not isinstance(row, list) or len(row) != width:
            raise ValueError(f"{source}: {name}[{i}] must be a list of {width} numbers, got {row!r}")
        for j, (v, bound) in enumerate(zip(row, bounds)):
            if v is None and name != "footholds":
                continue
            out[i, j] = check_number(v, f"{source}: {name}[{i}][{j}]", bound=bound)
    return out


def save_map_plan(path, plan: Plan, case, source: dict, params: SlipParams, hopper: NamedHopper) -> MapPlanRecord:
    """Write ``plan`` (found for ``case``, a ``planners.spatial_loop.MapCase`` whose map a suite records as
    ``source``, for ``hopper`` with ``params``' friction) to ``path``."""
    record = MapPlanRecord.from_plan(plan, case.apex, case.terrain, source, case.goal, params, hopper)
    record.save(path)
    return record


def is_map_plan(document) -> bool:
    """Whether a parsed plan document is a map plan (by its format's family: a version this code does not read is
    then refused as a map plan's, naming the version it reads)."""
    return isinstance(document, dict) and str(document.get("format", "")).startswith(MAP_PLAN_FAMILY)


def load_map_plan(path) -> MapPlanRecord:
    """Read a map plan file; a malformed one raises ValueError naming the file and the bad field."""
    return MapPlanRecord.from_dict(read_json(path, "plan file"), f"plan file {path}", Path(path).resolve().parent)
