"""Height-map suites: maps with start apexes and goals for the spatial hopper, stored as JSON
(``"format": "drakeslip-map-suite/1"``); the planar suites are ``planners.formats.suite``'s.

A document holds ``name``, ``goal`` {"x", "y"}, ``friction``, optionally ``hopper`` (``NamedHopper.to_record`` of
the hopper the suite was drawn for; none: the paper's) and ``cases``: [{"id", "map", "apex" {"x", "y", "z", "xdot",
"ydot"}, optionally "goal" {"x", "y"} (the suite's when left out)}]. A case's map is one of

* drawn: {"family", "seed", "difficulty", "length", "sha256"}: ``drakeslip.spatial.families``' map, drawn again on
  load (a map is 55,000 cells: a suite of them would be megabytes of JSON) and checked against its digest, so a
  changed generator or an edited record is refused rather than evaluated silently on other ground;
* a file: {"file", "sha256"}: a user's ``.npz`` or ``.asc`` height map (``load_height_map``), its path relative to
  the suite file.

A map's digest (``map_digest``) is the SHA-256 of its shape (two little-endian int64), its heights (little-endian
float64, rows in order, every hole the same NaN) and its cell and origin (three float64). Every field is checked on
load: a bad one is a ValueError naming it (``cases[3].apex.ydot``).

A drawn suite (``make_map_suite``) follows the planar paper protocol on maps: n_maps maps (the paper's 15) of a
family from seeds seed, seed + 1, ..., map i of n at difficulty i / (n - 1), so the suite spans every difficulty,
each paired with 10 starts (5 speeds 1.0-3.0 m/s x apex heights 0.8 and 1.0 m above the ground at x = -1 m, y = 0,
heading +x) and the goal (10, 0). For another hopper the maps are drawn in its lengths (``length`` = its leg /
0.5 m), the start and the goal are the paper's times that factor, and the start speeds and heights are the planar
suites' for that hopper (``planners.formats.suite_draw.suite_scales``: similar, then limited by its stiffness and
friction), so a case is the same kind of problem for it.
"""
from __future__ import annotations

import functools
import hashlib
import json
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from drakeslip.bounds import APEX_HEIGHT, APEX_SPEED, FRICTION, POSITION, SPEED
from drakeslip.hopper_file import NamedHopper, hopper_from_record, paper_hopper
from drakeslip.jobs.files import atomic_write, known_fields, read_json
from drakeslip.params import SlipParams, check_count, check_name, check_number
from drakeslip.spatial.families import DIFFICULTY, HEIGHT_MAP_FAMILIES, height_map_family
from drakeslip.spatial.heightmap import HeightMap, load_height_map
from drakeslip.spatial.state import check_apex3d
from drakeslip.units import PAPER
from planners.formats.suite import PAPER_HEIGHTS, PAPER_SPEEDS, PAPER_TERRAINS, START_X, required_field
from planners.formats.suite_draw import suite_scales
from planners.spatial_loop import MapCase

MAP_SUITE_FORMAT = "drakeslip-map-suite/1"
MAP_GOAL = (10.0, 0.0)    # [m] the paper's goal line at x = 10 m, on the path's line
START_Y = 0.0             # [m] the path's line: the maps' features lie across it
APEX_FIELDS = ("x", "y", "z", "xdot", "ydot")
DRAWN_FIELDS = ("family", "seed", "difficulty", "length", "sha256")


@dataclass(frozen=True)
class MapSuite:
    """A height-map suite: ``cases`` (``planners.spatial_loop.MapCase``), each case's map record in ``sources`` (in
    the same order: a drawn map's {"family", "seed", "difficulty", "length", "sha256"}, or a file's {"file": its
    absolute path, "sha256"}), the suite's ``goal`` (x, y), the ground's ``friction`` and the hopper it was drawn
    for (None: the paper's)."""

    name: str
    goal: tuple
    friction: float
    cases: tuple
    hopper: NamedHopper | None = None
    sources: tuple = ()

    def __post_init__(self):
        if len(self.sources) != len(self.cases):
            raise ValueError(f"a map suite needs one map record per case: {len(self.cases)} cases, "
                             f"{len(self.sources)} records")

    def to_dict(self, folder=None) -> dict:
        """The suite's document; a file map's path relative to ``folder`` (where the document is written; None:
        absolute)."""
        head = {"format": MAP_SUITE_FORMAT, "name": self.name, "goal": point_record(self.goal),
                "friction": self.friction}
        if self.hopper is not None:
            head["hopper"] = self.hopper.to_record()
        cases = []
        for case, source in zip(self.cases, self.sources):
            record = {"id": case.id, "map": map_record(source, folder),
                      "apex": dict(zip(APEX_FIELDS, (float(v) for v in case.apex)))}
            if tuple(case.goal) != tuple(self.goal):
                record["goal"] = point_record(case.goal)
            cases.append(record)
        return {**head, "cases": cases}


def point_record(point) -> dict:
    return {"x": float(point[0]), "y": float(point[1])}


def map_record(source: dict, folder=None) -> dict:
    """A case's map as a document holds it: a file's path made relative to ``folder`` when given."""
    if "file" not in source or folder is None:
        return dict(source)
    return {"file": os.path.relpath(source["file"], folder), "sha256": source["sha256"]}


def map_digest(height_map: HeightMap) -> str:
    """The SHA-256 (hex) a suite keeps of a map (module doc)."""
    heights = np.where(np.isnan(height_map.heights), np.nan, height_map.heights).astype("<f8")
    blob = (np.array(heights.shape, dtype="<i8").tobytes() + np.ascontiguousarray(heights).tobytes()
            + np.array([height_map.cell, *height_map.origin], dtype="<f8").tobytes())
    return hashlib.sha256(blob).hexdigest()


@functools.lru_cache(maxsize=64)
def drawn_map(family: str, seed: int, difficulty: float, length: float) -> HeightMap:
    """``height_map_family(family)(seed, difficulty, length)``, drawn once per process (ten cases share each map;
    a HeightMap's arrays are read-only, so sharing one is safe)."""
    return height_map_family(family)(seed, difficulty, length)


# many parameters: the planar make_suite's, each with the paper's value as its default, and the hopper
def make_map_suite(family: str, seed: int, n_maps: int = PAPER_TERRAINS, speeds=PAPER_SPEEDS, heights=PAPER_HEIGHTS,
                   goal=MAP_GOAL, hopper: NamedHopper | None = None, friction: float | None = None,
                   name: str | None = None) -> MapSuite:
    """``n_maps`` maps of ``family`` (seeds ``seed``, ``seed + 1``, ...; difficulty i / (n_maps - 1), 0 for one
    map) x every start (``speeds`` [m/s] x ``heights`` [m] above the ground), drawn for ``hopper`` (default: the
    paper's) as the module doc says; ``speeds``, ``heights`` and ``goal`` are the paper's hopper's, made the
    hopper's. ``friction`` defaults to the hopper's."""
    if family not in HEIGHT_MAP_FAMILIES:
        raise ValueError(f"unknown height map family {family!r}; choose one of {sorted(HEIGHT_MAP_FAMILIES)}")
    seed, n_maps = check_count(seed, "seed", low=0), check_count(n_maps, "n_maps")
    hopper = hopper or paper_hopper()
    scales = suite_scales(hopper.params, tuple(heights), tuple(speeds))
    length = scales.length   # the hopper's leg over the paper's: the maps' and the course's scale
    start = (START_X * length, START_Y * length)
    goal = tuple(float(g) * length for g in goal)
    cases, sources = [], []
    for i in range(n_maps):
        difficulty = i / (n_maps - 1) if n_maps > 1 else 0.0
        height_map = drawn_map(family, seed + i, difficulty, length)
        source = {"family": family, "seed": seed + i, "difficulty": difficulty, "length": length,
                  "sha256": map_digest(height_map)}
        ground = height_map.height_at(*start)
        for v in speeds:
            for z, factor in zip(heights, scales.start_heights):
                above, speed = z * length * factor, v * scales.speed
                apex = (*start, ground + above, speed, 0.0)
                case_id = f"{family}-{seed + i}-v{speed:g}-z{above:g}"
                cases.append(MapCase(case_id, height_map, check_map_start(apex, height_map, hopper.params, case_id),
                                     goal))
                sources.append(source)
    if len({c.id for c in cases}) != len(cases):
        raise ValueError("two cases share an id: start speeds or heights too close to tell apart")
    friction = hopper.params.friction if friction is None else check_number(friction, "friction", bound=FRICTION)
    return MapSuite(name or f"{family}-{seed}", goal, friction, tuple(cases),
                    None if hopper.params == PAPER else hopper, tuple(sources))


def check_map_start(apex, height_map: HeightMap, params: SlipParams, where: str) -> tuple:
    """``apex`` (x, y, z, xdot, ydot) as floats if it is a start inside the bounds in the hopper's units (as the
    planar ``drakeslip.state.check_start``): above solid ground, at most APEX_HEIGHT leg lengths above it, moving
    horizontally (the planners hop on) at most APEX_SPEED sqrt(g L0) fast; else ValueError naming ``where``."""
    try:
        apex = check_apex3d(apex, height_map, params)
    except ValueError as error:
        raise ValueError(f"{where}: {error}") from None
    x, y, z, xdot, ydot = apex
    ground, leg = height_map.height_at(x, y), params.leg_length
    if math.isnan(ground):
        raise ValueError(f"{where} (x={x:g}, y={y:g}) is over a hole of the map")
    if z - ground > APEX_HEIGHT.high * leg:
        raise ValueError(f"{where}.z={z:g} m is {z - ground:g} m above the ground: more than {APEX_HEIGHT.high:g} leg "
                         f"lengths ({APEX_HEIGHT.high * leg:g} m for this hopper; APEX_HEIGHT of drakeslip/bounds.py)")
    speed, fastest = math.hypot(xdot, ydot), APEX_SPEED.high * math.sqrt(params.gravity * leg)
    if not 0.0 < speed <= fastest:
        raise ValueError(f"{where}: horizontal speed {speed:g} m/s must be above 0 (the planners hop on) and at most "
                         f"{APEX_SPEED.high:g} sqrt(g L0) ({fastest:.4g} m/s for this hopper; APEX_SPEED of "
                         "drakeslip/bounds.py)")
    return apex


def save_map_suite(suite: MapSuite, path) -> None:
    """Write atomically (temporary file, then rename), file maps' paths relative to the file's folder."""
    with atomic_write(path, "w") as f:
        json.dump(suite.to_dict(Path(path).resolve().parent), f)


def is_map_suite(document) -> bool:
    """Whether a parsed suite document is a height-map suite (by its format)."""
    return isinstance(document, dict) and document.get("format") == MAP_SUITE_FORMAT


def load_map_suite(path) -> MapSuite:
    return map_suite_from_dict(read_json(path, "suite file"), f"suite file {path}", Path(path).resolve().parent)


def map_suite_from_dict(d, source: str = "map suite", folder=None) -> MapSuite:
    """Check every field of a map-suite document; a bad one raises ValueError naming it (e.g. cases[3].apex.ydot).
    File maps are read relative to ``folder`` (default: the working directory)."""
    fmt = required_field(d, "format", source)
    if fmt != MAP_SUITE_FORMAT:
        raise ValueError(f"{source}: format must be {MAP_SUITE_FORMAT!r}, got {fmt!r}")
    name = check_name(required_field(d, "name", source), f"{source}: name")
    known_fields(d, ("format", "name", "goal", "friction", "hopper", "cases"), source)
    goal = read_point(required_field(d, "goal", source), f"{source}: goal")
    friction = check_number(required_field(d, "friction", source), f"{source}: friction", bound=FRICTION)
    hopper = hopper_from_record(d["hopper"], f"{source}: hopper") if "hopper" in d else None
    params = (hopper or paper_hopper()).params   # whose units bound the starts
    raw_cases = required_field(d, "cases", source)
    if not isinstance(raw_cases, list) or not raw_cases:
        raise ValueError(f"{source}: cases must be a non-empty list")
    folder = Path.cwd() if folder is None else Path(folder)
    cases, sources, maps = [], [], {}
    for i, c in enumerate(raw_cases):
        where = f"{source}: cases[{i}]"
        case_id = check_name(required_field(c, "id", where), f"{where}.id")
        known_fields(c, ("id", "map", "apex", "goal"), where)
        if any(case.id == case_id for case in cases):
            raise ValueError(f"{where}.id must be unique, got {case_id!r} again")
        height_map, record = read_map(required_field(c, "map", where), f"{where}.map", folder, maps)
        apex = read_apex3d(required_field(c, "apex", where), f"{where}.apex")
        case_goal = read_point(c["goal"], f"{where}.goal") if "goal" in c else goal
        cases.append(MapCase(case_id, height_map, check_map_start(apex, height_map, params, f"{where}.apex"),
                             case_goal))
        sources.append(record)
    return MapSuite(name, goal, friction, tuple(cases), hopper, tuple(sources))


def read_point(p, where: str) -> tuple:
    """A point {"x", "y"} [m] of a JSON file, each inside POSITION; ValueError naming the field otherwise."""
    return tuple(check_number(required_field(p, k, where), f"{where}.{k}", bound=POSITION) for k in ("x", "y"))


def read_apex3d(a, where: str) -> tuple:
    """An apex {"x", "y", "z", "xdot", "ydot"} of a JSON file, positions inside POSITION and speeds inside SPEED;
    ValueError naming the field otherwise."""
    return tuple(check_number(required_field(a, k, where), f"{where}.{k}", bound=POSITION if k in "xyz" else SPEED)
                 for k in APEX_FIELDS)


def read_map(m, where: str, folder: Path, maps: dict) -> tuple:
    """(the HeightMap, its record with a file's path made absolute) of a case's map record, drawn or read once per
    suite (``maps``: by record), its digest checked; ValueError naming the field otherwise."""
    required_field(m, "sha256", where)
    if ("family" in m) == ("file" in m):
        raise ValueError(f"{where} must name either a drawn map (family, seed, difficulty, length) or a file")
    if "file" in m:
        path = m["file"]
        if not isinstance(path, str) or not path:
            raise ValueError(f"{where}.file must be a path (relative to the suite file), got {path!r}")
        record = {"file": str((folder / path).resolve()), "sha256": m["sha256"]}
    else:
        record = drawn_record(m, where)
    key = json.dumps(record, sort_keys=True)
    if key not in maps:
        maps[key] = built_map(record, where)
    return maps[key], record


def drawn_record(m: dict, where: str) -> dict:
    """A drawn map's record with each field checked (the family known, the seed a count, the difficulty in [0, 1],
    the length positive)."""
    family = required_field(m, "family", where)
    if not isinstance(family, str) or family not in HEIGHT_MAP_FAMILIES:
        raise ValueError(f"{where}.family must be one of {sorted(HEIGHT_MAP_FAMILIES)}, got {family!r}")
    return {"family": family, "seed": check_count(required_field(m, "seed", where), f"{where}.seed", low=0),
            "difficulty": check_number(required_field(m, "difficulty", where), f"{where}.difficulty",
                                       bound=DIFFICULTY),
            "length": check_number(required_field(m, "length", where), f"{where}.length", positive=True),
            "sha256": m["sha256"]}


def built_map(record: dict, where: str) -> HeightMap:
    """The map of a checked record, drawn or read, if its digest is the record's."""
    expected = record["sha256"]
    if not isinstance(expected, str) or len(expected) != 64 or any(ch not in "0123456789abcdef" for ch in expected):
        raise ValueError(f"{where}.sha256 must be 64 lowercase hex digits, got {expected!r}")
    try:
        if "file" in record:
            height_map, what = load_height_map(record["file"]), f"the height map file {record['file']}"
        else:
            height_map = drawn_map(record["family"], record["seed"], record["difficulty"], record["length"])
            what = f"the {record['family']!r} map of seed {record['seed']} at difficulty {record['difficulty']:g}"
    except ValueError as error:
        raise ValueError(f"{where}: {error}") from None
    found = map_digest(height_map)
    if found != expected:
        raise ValueError(f"{where}.sha256: {what} has digest {found[:16]}..., not the suite's {expected[:16]}... "
                         "(the map or its generator changed since the suite was written)")
    return height_map


def task_map(source: dict, height_map: HeightMap):
    """What an evaluation task carries of a case's map: a drawn map's record (the worker draws it again, in
    milliseconds), or a file's map itself (workers read no files: they may be on other machines)."""
    return height_map if "file" in source else {k: source[k] for k in DRAWN_FIELDS[:-1]}


def map_of_task(entry) -> HeightMap:
    """The map ``task_map`` made ``entry`` of."""
    return entry if isinstance(entry, HeightMap) else drawn_map(**entry)
