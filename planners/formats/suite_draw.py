"""Suites for any hopper: the paper's terrain families drawn in a hopper's units, and suites from terrain files.

A suite drawn for a hopper holds the paper's problems made similar (``drakeslip.units``): every terrain length and
height (ditch widths, island lengths, step heights, the level band, segment lengths, the cell size, the flat
run-up), the start x, the goal and the start heights times the hopper's length factor, the start speeds times its
speed factor. The terrains are the paper's draws (same seeds) scaled, so the cases of two hoppers correspond one to
one; for the paper's hopper every factor is 1.0 and the suite equals ``make_suite``'s. A suite records its hopper
(``Suite.hopper``) unless that is the paper's.
"""
from __future__ import annotations

from pathlib import Path

from drakeslip import ApexState
from drakeslip.hopper_file import Hopper, paper_hopper
from drakeslip.params import check_number
from drakeslip.terrain import TERRAIN_FAMILIES
from drakeslip.terrain_file import load_terrain, scaled_terrain
from drakeslip.units import PAPER
from planners.formats.suite import (PAPER_GOAL_X, PAPER_HEIGHTS, PAPER_SPEEDS, PAPER_TERRAINS, START_X, Case,
                                    Suite)

PROFILE_SUFFIXES = (".csv", ".txt")   # the files of a folder of profiles that are read


def draw_suite(family: str, seed: int, hopper: Hopper | None = None, n_terrains: int = PAPER_TERRAINS,
               speeds=PAPER_SPEEDS, heights=PAPER_HEIGHTS, goal_x: float = PAPER_GOAL_X,
               friction: float | None = None, name: str | None = None) -> Suite:
    """``make_suite(family, seed, ...)`` for ``hopper`` (default: the paper's): the same arguments, in the paper's
    units (speeds [m/s] of the paper's hopper, heights above the ground and ``goal_x`` [m]), each case scaled to
    the hopper (see the module doc). ``friction`` defaults to the hopper's."""
    if family not in TERRAIN_FAMILIES:
        raise ValueError(f"unknown terrain family {family!r}; choose one of {sorted(TERRAIN_FAMILIES)}")
    hopper = hopper or paper_hopper()
    units = hopper.units
    start_x = START_X * units.length
    cases = []
    for i in range(n_terrains):
        terrain = scaled_terrain(TERRAIN_FAMILIES[family](seed + i), units.length)
        for v in speeds:
            for z in heights:
                apex = ApexState(start_x, z * units.length + terrain.height_at(start_x), v * units.speed)
                cases.append(Case(f"{family}-{seed + i}-v{apex.xdot:g}-z{z * units.length:g}", terrain, apex))
    return suite_for(hopper, name or f"{family}-{seed}", goal_x * units.length, friction, cases)


def suite_from_terrains(profiles, hopper: Hopper | None = None, speeds=None, heights=None,
                        start_x: float | None = None, goal_x: float | None = None, friction: float | None = None,
                        name: str | None = None, cell: float | None = None) -> Suite:
    """A suite of every terrain file in ``profiles`` (a folder: its .csv and .txt files, by name; or a list of
    files) x every start apex: forward ``speeds`` [m/s] x ``heights`` [m] above the ground at ``start_x``. What is
    not given is the paper's value in ``hopper``'s units (``draw_suite``'s starts); ``friction`` defaults to the
    hopper's, ``cell`` is ``load_terrain``'s. Case ids are ``<file stem>-v<speed>-z<height>``."""
    hopper = hopper or paper_hopper()
    units = hopper.units
    paths = profile_paths(profiles)
    speeds = [check_number(v, "start speed", positive=True)
              for v in (speeds or [v * units.speed for v in PAPER_SPEEDS])]
    heights = [check_number(z, "start height", positive=True)
               for z in (heights or [z * units.length for z in PAPER_HEIGHTS])]
    start_x = START_X * units.length if start_x is None else check_number(start_x, "start_x")
    goal_x = PAPER_GOAL_X * units.length if goal_x is None else check_number(goal_x, "goal_x")
    if not goal_x > start_x:
        raise ValueError(f"goal_x={goal_x:g} must lie ahead of start_x={start_x:g}")
    cases, stems = [], {}
    for path in paths:
        if path.stem in stems:
            raise ValueError(f"terrain files {stems[path.stem]} and {path} share the name {path.stem!r}, which "
                             f"names their cases")
        stems[path.stem] = path
        terrain = load_terrain(path, cell)
        if terrain.is_ditch_at(start_x):
            raise ValueError(f"terrain file {path}: the start x={start_x:g} is over a ditch")
        for v in speeds:
            for z in heights:
                apex = ApexState(start_x, z + terrain.height_at(start_x), v)
                cases.append(Case(f"{path.stem}-v{v:g}-z{z:g}", terrain, apex))
    default_name = Path(profiles).stem if isinstance(profiles, (str, Path)) else "profiles"
    return suite_for(hopper, name or default_name, goal_x, friction, cases)


def profile_paths(profiles) -> list[Path]:
    """The terrain files ``profiles`` names: a folder's .csv and .txt files sorted by name, or the given files."""
    if isinstance(profiles, (str, Path)) and Path(profiles).is_dir():
        paths = sorted(p for p in Path(profiles).iterdir() if p.suffix.lower() in PROFILE_SUFFIXES and p.is_file())
        if not paths:
            raise ValueError(f"terrain folder {profiles} has no {' or '.join(PROFILE_SUFFIXES)} files")
        return paths
    paths = [Path(profiles)] if isinstance(profiles, (str, Path)) else [Path(p) for p in profiles]
    if not paths:
        raise ValueError("suite_from_terrains needs at least one terrain file")
    for path in paths:
        if not path.is_file():
            raise FileNotFoundError(f"no such terrain file: {path}")
    return paths


def suite_for(hopper: Hopper, name: str, goal_x: float, friction: float | None, cases) -> Suite:
    """A Suite of ``cases`` for ``hopper``, which it records unless it is the paper's; ValueError when two cases
    share an id (start speeds or heights that agree to the 6 digits an id shows)."""
    ids = [c.id for c in cases]
    if len(set(ids)) != len(ids):
        twice = next(i for i in ids if ids.count(i) > 1)
        raise ValueError(f"two cases are both {twice!r}: start speeds or heights too close to tell apart")
    friction = hopper.params.friction if friction is None else check_number(friction, "friction", positive=True)
    return Suite(name, goal_x, friction, tuple(cases), None if hopper.params == PAPER else hopper)


def suite_hopper(suite: Suite) -> Hopper:
    """The hopper a suite is for: its recorded one, or the paper's."""
    return suite.hopper or paper_hopper()
