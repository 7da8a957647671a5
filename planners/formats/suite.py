"""Test suites: terrains with initial apex states, stored as JSON (``"format": "drakeslip-suite/1"``).

Two fields are optional: ``"hopper"`` (the record, ``NamedHopper.to_record``, of the hopper a suite was drawn for; a
suite without one is for the paper's hopper) and a terrain's ``"ditch_height"`` (written where it is not
DITCH_HEIGHT, as for a terrain file whose solid ground reaches below -1 m)."""
from __future__ import annotations

import json
from dataclasses import dataclass

from drakeslip import ApexState, SlipParams, Terrain
from drakeslip.hopper_file import NamedHopper, hopper_from_record
from drakeslip.jobs.files import atomic_write, known_fields, read_json
from drakeslip.bounds import CELL, FRICTION, POSITION, TERRAIN_START
from drakeslip.params import check_name, check_number
from drakeslip.state import APEX_BOUNDS, check_start
from drakeslip.terrain import DITCH_HEIGHT, family as terrain_family

SUITE_FORMAT = "drakeslip-suite/1"
# The paper's protocol: 15 terrains per family, goal at x = 10 m, friction 0.8. Each terrain is paired with
# 10 initial apex states: 5 forward speeds x 2 apex heights above the ground, from a slow low hop (energy
# for about 0.85 m of height: it cannot climb the highest step levels) to a fast high one (1.46 m: it must
# trade height for speed or bottom out). They start at x = -1 m: the terrain is flat for x < 1 m, and a 2 m
# run-up lets the fastest start land before the first obstacle (from x = 0, a 3 m/s hop 0.9 m high can only
# land at 1.0-1.2 m, in the first ditch of every ditch world).
PAPER_TERRAINS = 15
PAPER_SPEEDS = (1.0, 1.5, 2.0, 2.5, 3.0)
PAPER_HEIGHTS = (0.8, 1.0)
START_X = -1.0
PAPER_GOAL_X = 10.0
PAPER_FRICTION = 0.8
# Base terrain seeds of the committed suites, suites/ditch.json and suites/step.json (terrain i uses base + i);
# fresh suites use other bases.
COMMITTED_SEEDS = {"ditch": 1000, "step": 2000}


@dataclass(frozen=True)
class Case:
    id: str
    terrain: Terrain
    apex: ApexState


@dataclass(frozen=True)
class Suite:
    name: str
    goal_x: float
    friction: float
    cases: tuple
    hopper: NamedHopper | None = None   # the hopper the suite was drawn for; None: the paper's

    def to_dict(self) -> dict:
        head = {"format": SUITE_FORMAT, "name": self.name, "goal_x": self.goal_x, "friction": self.friction}
        if self.hopper is not None:
            head["hopper"] = self.hopper.to_record()
        return {**head, "cases": [{"id": c.id, "terrain": terrain_record(c.terrain), "apex": c.apex._asdict()}
                                  for c in self.cases]}


def terrain_record(terrain: Terrain) -> dict:
    """A terrain as a suite stores it: ``Terrain.to_dict()``, with ``ditch_height`` where it is not DITCH_HEIGHT."""
    record = terrain.to_dict()
    if terrain.ditch_height != DITCH_HEIGHT:
        record["ditch_height"] = terrain.ditch_height
    return record


def make_suite(family: str, seed: int, n_terrains: int = PAPER_TERRAINS, speeds=PAPER_SPEEDS,
               heights=PAPER_HEIGHTS, goal_x: float = PAPER_GOAL_X, friction: float = PAPER_FRICTION,
               name: str | None = None) -> Suite:
    """``n_terrains`` terrains of ``family`` (seeds ``seed``, ``seed + 1``, ...) x every (speed, height)."""
    generate = terrain_family(family)
    cases = []
    for i in range(n_terrains):
        terrain = generate(seed + i)
        for v in speeds:
            for z in heights:
                cases.append(Case(f"{family}-{seed + i}-v{v:g}-z{z:g}", terrain,
                                  ApexState(START_X, z + terrain.height_at(START_X), v)))
    return Suite(name or f"{family}-{seed}", goal_x, friction, tuple(cases))


def save_suite(suite: Suite, path) -> None:
    """Write atomically (temporary file, then rename)."""
    with atomic_write(path, "w") as f:
        json.dump(suite.to_dict(), f)


def required_field(d, key, where):
    """``d[key]``, or a ValueError naming ``where`` when d is not an object or lacks the key (for JSON files)."""
    if not isinstance(d, dict):
        raise ValueError(f"{where} must be an object, got {type(d).__name__}")
    if key not in d:
        raise ValueError(f"{where} is missing the field {key!r}")
    return d[key]


def suite_from_dict(d, source: str = "suite") -> Suite:
    """Check every field of a suite document; a bad one raises ValueError naming it (e.g. cases[3].apex.z)."""
    fmt = required_field(d, "format", source)
    if fmt != SUITE_FORMAT:
        raise ValueError(f"{source}: format must be {SUITE_FORMAT!r}, got {fmt!r}")
    name = check_name(required_field(d, "name", source), f"{source}: name")
    known_fields(d, ("format", "name", "goal_x", "friction", "hopper", "cases"), source)
    goal_x = check_number(required_field(d, "goal_x", source), f"{source}: goal_x", bound=POSITION)
    friction = check_number(required_field(d, "friction", source), f"{source}: friction", bound=FRICTION)
    hopper = hopper_from_record(d["hopper"], f"{source}: hopper") if "hopper" in d else None
    params = hopper.params if hopper is not None else SlipParams()   # whose units bound the starts
    raw_cases = required_field(d, "cases", source)
    if not isinstance(raw_cases, list) or not raw_cases:
        raise ValueError(f"{source}: cases must be a non-empty list")
    cases, ids = [], set()
    for i, c in enumerate(raw_cases):
        where = f"{source}: cases[{i}]"
        case_id = check_name(required_field(c, "id", where), f"{where}.id")
        known_fields(c, ("id", "terrain", "apex"), where)
        if case_id in ids:
            raise ValueError(f"{where}.id must be unique, got {case_id!r} again")
        ids.add(case_id)
        t = required_field(c, "terrain", where)
        x0 = check_number(required_field(t, "x0", f"{where}.terrain"), f"{where}.terrain.x0", bound=TERRAIN_START)
        cell = check_number(required_field(t, "cell", f"{where}.terrain"), f"{where}.terrain.cell", bound=CELL)
        heights = required_field(t, "heights", f"{where}.terrain")
        known_fields(t, ("x0", "cell", "heights", "ditch_height"), f"{where}.terrain")
        if not isinstance(heights, list) or not heights:
            raise ValueError(f"{where}.terrain.heights must be a non-empty list of numbers")
        ditch_height = check_number(t["ditch_height"], f"{where}.terrain.ditch_height", bound=POSITION) \
            if "ditch_height" in t else DITCH_HEIGHT
        terrain = Terrain([check_number(h, f"{where}.terrain.heights[{j}]", bound=POSITION)
                           for j, h in enumerate(heights)], cell=cell, x0=x0, ditch_height=ditch_height)
        apex = read_apex(required_field(c, "apex", where), f"{where}.apex")
        if apex.z <= terrain.height_at(apex.x):
            raise ValueError(f"{where}.apex.z={apex.z} is not above the terrain at x={apex.x}")
        if apex.xdot <= 0:
            raise ValueError(f"{where}.apex.xdot must be positive, got {apex.xdot}")
        if apex.x >= goal_x:   # a run would succeed with no hop, and a plan would hold no foothold
            raise ValueError(f"{where}.apex.x={apex.x} is not before the suite's goal_x={goal_x}")
        cases.append(Case(case_id, terrain, check_start(apex, terrain, params, f"{where}.apex")))
    return Suite(name, goal_x, friction, tuple(cases), hopper)


def read_apex(a, where: str) -> ApexState:
    """An apex object ``{"x", "z", "xdot"}`` of a JSON file, each field checked against its bound
    (``drakeslip.state.APEX_BOUNDS``); a ValueError naming ``where`` and the field otherwise."""
    return ApexState(*(check_number(required_field(a, k, where), f"{where}.{k}", bound=bound)
                       for k, bound in zip(ApexState._fields, APEX_BOUNDS)))


def load_suite(path) -> Suite:
    return suite_from_dict(read_json(path, "suite file"), source=f"suite file {path}")
