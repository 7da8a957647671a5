"""Suites for any hopper: the paper's terrain families drawn in a hopper's units, and suites from terrain files.

A suite drawn for a hopper holds the paper's problems made the same kind of problem for that hopper
(``suite_scales``). Every terrain length (ditch widths, island and segment lengths, the cell size, the flat run-up),
the start x and the goal are the paper's times the hopper's length factor (``drakeslip.units``). What a hopper can
do besides covering ground depends on its dimensionless stiffness kd = k L0 / (m g), its stroke s (the fraction of
the leg the spring can compress) and its friction, which similarity cannot scale away, so the rest follows its
physics:

* start heights: a drop from the start apex compresses the spring by the same fraction of the stroke as the paper's
  start does (68 % and 85 % from the paper's 0.8 m and 1.0 m). Falling vertically from h leg lengths above the
  ground, the spring's energy k c^2 / 2 at compression c L0 equals m g (h - 1 + c) L0, so the start that
  compresses a fraction f of the stroke is h = 1 + ((kd f s - 1)^2 - 1) / (2 kd) leg lengths above the ground:
  never higher than the paper's start in leg lengths (a stiffer hopper keeps the paper's start, made similar), and
  never under STANDING_HEIGHT leg lengths (a flight to start from).
* start speeds: the paper's in Froude units (times the speed factor) times min(1, sqrt(kd / kd_paper)) (a softer
  spring's longer stance sweeps the leg through a wider angle at the same Froude speed: at sqrt(kd / kd_paper) of
  it, the angle is the paper's) times min(1, atan(mu) / atan(0.8)) (less friction, a narrower cone of leg angles).
* terrain heights (step changes, the level band): the paper's times the length factor times the ratio of the
  hopper's highest start above its leg length to the paper's (at most 1): the height a hopper can climb and drop
  without bottoming out is what its start keeps above L0.
* ditch widths and the course (from the start to the goal): the paper's times the length factor times the ratio
  of the hopper's stride to the paper's (at most 1), the stride being the median over the suite's starts of the
  longest distance between the footholds of two hops on flat ground, in leg lengths (``stride``). A softer or more
  slippery hopper covers less ground a hop (kd 10: about half the paper's); a ditch is an obstacle by how much of
  a hop it takes, and a case asks for about as many hops as the paper's. What a foot lands on (islands, steps'
  segments, the cells) and the flat run-up stay in leg lengths.

The terrains are the paper's draws (same seeds) scaled, so the cases of two hoppers correspond one to one; for the
paper's hopper every factor is exactly 1.0 and the suite equals ``make_suite``'s. A suite records its hopper
(``Suite.hopper``) unless that is the paper's.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import functools

import numpy as np

from drakeslip import ApexState, SlipParams, Terrain, step_batch
from drakeslip.hopper_file import NamedHopper, check_same_hopper, paper_hopper
from drakeslip.params import check_number
from drakeslip.state import check_start
from drakeslip.terrain import DITCH_WIDTH, TERRAIN_FAMILIES
from drakeslip.terrain_file import gaps_of, load_terrain, terrain_with_gaps
from drakeslip.units import PAPER, units_of
from planners.formats.suite import (PAPER_GOAL_X, PAPER_HEIGHTS, PAPER_SPEEDS, PAPER_TERRAINS, START_X, Case,
                                    Suite)

PROFILE_SUFFIXES = (".csv", ".txt")   # the files of a folder of profiles that are read
STANDING_HEIGHT = 1.05   # [leg lengths] the lowest start apex above the ground a drawn suite gives
STRIDE_ANGLES = 41       # leg angles across the friction cone tried at each hop of ``stride``
# examples/plan_and_hop.py's case for the paper's hopper (``one_case``): start speed [m/s], height above the
# ground [m], and the course from the start to the goal [m]
DEMO_SPEED, DEMO_HEIGHT, DEMO_COURSE = 2.0, 0.9, 10.0


@dataclass(frozen=True)
class SuiteScales:
    """What multiplies the paper's numbers in a suite drawn for a hopper (see the module doc): ``length`` (terrain
    lengths, the cells, start x, goal), ``speed`` (start speeds), ``terrain_height`` (terrain heights) and
    ``start_heights`` (each of the paper's start heights above the ground, in its order) and ``stride`` (ditch
    widths and the course from the start to the goal)."""

    length: float
    speed: float
    terrain_height: float
    start_heights: tuple
    stride: float


def stroke(params: SlipParams) -> float:
    """The fraction of the leg the spring can compress: 1 - min_leg_length / leg_length."""
    return 1.0 - params.min_leg_length / params.leg_length


def drop_height(kd: float, compression: float) -> float:
    """The height above the ground [leg lengths] of an apex whose vertical drop compresses the spring of
    dimensionless stiffness ``kd`` by ``compression`` leg lengths: 1 + ((kd c - 1)^2 - 1) / (2 kd)."""
    return 1.0 + ((kd * compression - 1.0) ** 2 - 1.0) / (2.0 * kd)


def start_height_factor(params: SlipParams, height: float) -> float:
    """The start height above the ground for ``params`` over the paper's ``height`` [m] made similar (at most 1):
    the height whose drop compresses the spring by the fraction of the stroke the paper's drop from ``height``
    does, at least STANDING_HEIGHT leg lengths."""
    kd_paper, above = units_of(PAPER).stiffness, height / PAPER.leg_length
    if above <= 1.0:   # the paper's apex does not clear its leg: nothing to match
        return 1.0
    compression = (1.0 + math.sqrt(1.0 + 2.0 * kd_paper * (above - 1.0))) / kd_paper   # leg lengths
    fraction = compression / stroke(PAPER)
    mine = drop_height(units_of(params).stiffness, fraction * stroke(params))
    paper = drop_height(kd_paper, fraction * stroke(PAPER))
    return min(1.0, max(mine, STANDING_HEIGHT) / paper)


@functools.lru_cache(maxsize=64)
def stride(params: SlipParams, starts: tuple) -> float:
    """The median over ``starts`` ((height above the ground [m], speed [m/s]) apexes) of the longest distance
    [leg lengths] between the footholds of two hops on flat ground, each hop's leg angle one of STRIDE_ANGLES
    across the friction cone, the second hop keeping a forward speed."""
    leg = params.leg_length
    ground = Terrain.flat(0.0, cell=0.1 * leg, x0=-5.0 * leg, length=60.0 * leg)
    angles = np.linspace(-0.99, 0.99, STRIDE_ANGLES) * math.atan(params.friction)
    longest = []
    for height, speed in starts:
        first = step_batch((0.0, height, speed), angles, ground, params)
        ok = np.flatnonzero(first.ok)
        apexes = np.repeat(np.column_stack([first.next_x, first.next_z, first.next_xdot])[ok], angles.size, axis=0)
        second = step_batch(apexes, np.tile(angles, ok.size), ground, params)
        reach = np.where(second.ok, second.touchdown_x - np.repeat(first.touchdown_x[ok], angles.size), 0.0)
        longest.append(float(reach.max(initial=0.0)) / leg)
    return float(np.median(longest))


def suite_scales(params: SlipParams, heights=PAPER_HEIGHTS, speeds=PAPER_SPEEDS) -> SuiteScales:
    """The factors of a suite drawn for the hopper ``params`` from the paper's start ``heights`` [m] and
    ``speeds`` [m/s] (module doc)."""
    units = units_of(params)
    factors = tuple(start_height_factor(params, z) for z in heights)
    top = max(range(len(heights)), key=lambda i: heights[i])
    paper_top = heights[top] / PAPER.leg_length
    climb = min(1.0, (paper_top * factors[top] - 1.0) / (paper_top - 1.0)) if paper_top > 1.0 else 1.0
    speed = (units.speed * min(1.0, math.sqrt(units.stiffness / units_of(PAPER).stiffness))
             * min(1.0, math.atan(params.friction) / math.atan(PAPER.friction)))
    mine = tuple((z * units.length * f, v * speed) for z, f in zip(heights, factors) for v in speeds)
    papers = tuple((z, v) for z in heights for v in speeds)
    if mine == papers:   # the paper's hopper: its own stride, whatever it is
        ditch = 1.0
    elif stride(PAPER, papers) == 0.0:
        raise ValueError(f"no start of heights {list(heights)} m and speeds {list(speeds)} m/s takes the paper's "
                         "hopper two hops on flat ground (its spring bottoms out, or it stalls): the suite's ditch "
                         "widths and course, scaled by that stride, have nothing to scale")
    else:
        ditch = min(1.0, stride(params, mine) / stride(PAPER, papers))
    return SuiteScales(units.length, speed, units.length * climb, factors, units.length * ditch)


def course_end(start_x: float, goal_x: float, scales: SuiteScales) -> float:
    """The goal for the hopper of ``scales`` starting at ``start_x`` [m]: the paper's course from START_X to
    ``goal_x`` [m] times ``scales.stride``."""
    return start_x + (goal_x - START_X) * scales.stride


def hopper_terrain(family: str, seed: int, scales: SuiteScales) -> Terrain:
    """The paper's terrain of ``family`` and ``seed`` for the hopper of ``scales`` (module doc): drawn with its
    ditches ``scales.stride / scales.length`` as wide (the same draws: every island and step where it was, the
    ditches narrower), then lengths times ``scales.length``, heights times ``scales.terrain_height``, ditches kept
    ditches (``drakeslip.terrain_file.terrain_with_gaps``)."""
    ditches = {}
    if family in ("ditch", "mixed"):
        ditches["ditch_width"] = tuple(w * (scales.stride / scales.length) for w in DITCH_WIDTH)
    terrain = TERRAIN_FAMILIES[family](seed, **ditches)
    return terrain_with_gaps(gaps_of(terrain) * scales.terrain_height, terrain.cell * scales.length,
                             terrain.x0 * scales.length)


# many parameters: ``make_suite``'s, each with the paper's value as its default, and the hopper to draw them for
def draw_suite(family: str, seed: int, hopper: NamedHopper | None = None, n_terrains: int = PAPER_TERRAINS,
               speeds=PAPER_SPEEDS, heights=PAPER_HEIGHTS, goal_x: float = PAPER_GOAL_X,
               friction: float | None = None, name: str | None = None) -> Suite:
    """``make_suite(family, seed, ...)`` for ``hopper`` (default: the paper's): the same arguments, in the paper's
    units (speeds [m/s] of the paper's hopper, heights above the ground and ``goal_x`` [m]), each case made the
    same kind of problem for the hopper (``suite_scales``, see the module doc). ``friction`` defaults to the
    hopper's."""
    if family not in TERRAIN_FAMILIES:
        raise ValueError(f"unknown terrain family {family!r}; choose one of {sorted(TERRAIN_FAMILIES)}")
    for z in heights:   # the paper's starts inside the start bounds: made the hopper's, so are its own
        for v in speeds:
            check_start((START_X, z, v), Terrain.flat(), PAPER, f"the paper's start at {v:g} m/s: its apex")
    hopper = hopper or paper_hopper()
    scales = suite_scales(hopper.params, tuple(heights), tuple(speeds))
    start_x = START_X * scales.length
    cases = []
    for i in range(n_terrains):
        terrain = hopper_terrain(family, seed + i, scales)
        for v in speeds:
            for z, factor in zip(heights, scales.start_heights):
                above = z * scales.length * factor
                apex = ApexState(start_x, above + terrain.height_at(start_x), v * scales.speed)
                cases.append(Case(f"{family}-{seed + i}-v{apex.xdot:g}-z{above:g}", terrain, apex))
    return suite_for(hopper, name or f"{family}-{seed}", course_end(start_x, goal_x, scales), friction, cases)


# many parameters: the terrain files, then the suite's options, each defaulting to the paper's made the hopper's
def suite_from_terrains(profiles, hopper: NamedHopper | None = None, speeds=None, heights=None,
                        start_x: float | None = None, goal_x: float | None = None, friction: float | None = None,
                        name: str | None = None, cell: float | None = None) -> Suite:
    """A suite of every terrain file in ``profiles`` (a folder: its .csv and .txt files, by name; or a list of
    files) x every start apex: forward ``speeds`` [m/s] x ``heights`` [m] above the ground at ``start_x``. What is
    not given is the paper's value made the hopper's (``draw_suite``'s starts, ``suite_scales``); ``friction``
    defaults to the hopper's, ``cell`` is ``load_terrain``'s. Case ids are ``<file stem>-v<speed>-z<height>``."""
    hopper = hopper or paper_hopper()
    scales = suite_scales(hopper.params)
    paths = profile_paths(profiles)
    speeds = [check_number(v, "start speed", positive=True)
              for v in (speeds or [v * scales.speed for v in PAPER_SPEEDS])]
    heights = [check_number(z, "start height", positive=True)
               for z in (heights or [z * scales.length * f for z, f in zip(PAPER_HEIGHTS, scales.start_heights)])]
    start_x = START_X * scales.length if start_x is None else check_number(start_x, "start_x")
    goal_x = course_end(start_x, PAPER_GOAL_X, scales) if goal_x is None else check_number(goal_x, "goal_x")
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


def suite_for(hopper: NamedHopper, name: str, goal_x: float, friction: float | None, cases) -> Suite:
    """A Suite of ``cases`` for ``hopper``, which it records unless it is the paper's; ValueError when two cases
    share an id (start speeds or heights that agree to the 6 digits an id shows) or a start lies outside the bounds
    in the hopper's units (``drakeslip.state.check_start``)."""
    for case in cases:
        check_start(case.apex, case.terrain, hopper.params, f"case {case.id!r}: the start apex")
    ids = [c.id for c in cases]
    if len(set(ids)) != len(ids):
        twice = next(i for i in ids if ids.count(i) > 1)
        raise ValueError(f"two cases are both {twice!r}: start speeds or heights too close to tell apart")
    friction = hopper.params.friction if friction is None else check_number(friction, "friction", positive=True)
    return Suite(name, goal_x, friction, tuple(cases), None if hopper.params == PAPER else hopper)


def suite_hopper(suite: Suite) -> NamedHopper:
    """The hopper a suite is for: its recorded one, or the paper's."""
    return suite.hopper or paper_hopper()


def hopper_for_suite(suite: Suite, hopper: NamedHopper | None = None) -> NamedHopper:
    """The hopper to run ``suite``'s cases with: ``hopper`` (e.g. a hopper folder, whose weights planners then
    read) when it is the one the suite was drawn for (the same body: ``check_same_hopper``), the suite's own when
    ``hopper`` is None; another hopper is refused: ValueError in one line."""
    drawn = suite_hopper(suite)
    if hopper is None:
        return drawn
    try:
        check_same_hopper(hopper, drawn.params, f"suite {suite.name!r}")
    except ValueError as error:
        raise ValueError(f"{error}; draw a suite for it with examples/make_suites.py --hopper") from None
    return hopper


def check_solid_start(terrain: Terrain, x: float) -> None:
    """ValueError in one line unless ``x`` lies on solid ground of ``terrain``, between its ends: a start past them
    hops on ground the terrain does not describe."""
    if not terrain.x0 <= x < terrain.x_end or terrain.is_ditch_at(x):
        raise ValueError(f"the start x={x:g} is not on solid ground of the terrain "
                         f"[{terrain.x0:g}, {terrain.x_end:g}) m")


def one_case(terrain, seed: int = 0, hopper: NamedHopper | None = None, speed: float | None = None,
             height: float | None = None, goal_x: float | None = None, start_x: float | None = None) -> Suite:
    """A suite of one case for ``hopper`` (default: the paper's), as examples/plan_and_hop.py runs it: on the draw
    from ``seed`` of the family ``terrain`` names, made the hopper's as ``draw_suite`` makes it (``hopper_terrain``),
    or on ``terrain`` itself (a Terrain, e.g. from a terrain file). The start apex at ``start_x`` [m], ``speed``
    [m/s] forward and ``height`` [m] above the ground there, and the goal at ``goal_x`` [m]: each, when given, as
    given. Left out: the start at x = 0 (on a Terrain that has no solid ground there, one leg length past the start
    of its first solid stretch), the paper's demo start (2 m/s, 0.9 m) and course (10 m from the start) made the
    hopper's (``suite_scales``), the goal on a Terrain at most up to one leg length before its end. For the paper's
    hopper the defaults are exactly the paper's numbers and a family's terrain is its generator's."""
    hopper = hopper or paper_hopper()
    scales = suite_scales(hopper.params, (DEMO_HEIGHT,), (DEMO_SPEED,))
    leg = hopper.params.leg_length
    if isinstance(terrain, str):
        if terrain not in TERRAIN_FAMILIES:
            raise ValueError(f"unknown terrain family {terrain!r}; choose one of {sorted(TERRAIN_FAMILIES)}")
        name, terrain, end = f"{terrain}-{seed}", hopper_terrain(terrain, seed, scales), math.inf
    elif isinstance(terrain, Terrain):
        name, end = "terrain", terrain.x_end - leg
    else:
        raise TypeError(f"terrain must be a family name or a Terrain, got {type(terrain).__name__}")
    start_x = (first_foothold(terrain, leg) if start_x is None else check_number(start_x, "start_x"))
    check_solid_start(terrain, start_x)
    above = (DEMO_HEIGHT * scales.length * scales.start_heights[0] if height is None
             else check_number(height, "start height", positive=True))
    speed = DEMO_SPEED * scales.speed if speed is None else check_number(speed, "start speed", positive=True)
    goal_x = min(start_x + DEMO_COURSE * scales.stride, end) if goal_x is None else check_number(goal_x, "goal_x")
    if not start_x < goal_x < terrain.x_end:
        raise ValueError(f"the goal x={goal_x:g} must lie ahead of the start x={start_x:g} and on the terrain, "
                         f"which ends at x={terrain.x_end:g}")
    apex = ApexState(start_x, terrain.height_at(start_x) + above, speed)
    return suite_for(hopper, name, goal_x, None, [Case(f"{name}-v{speed:g}-z{above:g}", terrain, apex)])


def first_foothold(terrain: Terrain, leg: float) -> float:
    """x = 0 when the terrain has solid ground there, else one leg length past the start of its first solid
    stretch at least that long (or the stretch's middle when none is), ValueError on a terrain with none."""
    if terrain.x0 <= 0.0 < terrain.x_end and not terrain.is_ditch_at(0.0):
        return 0.0
    solid = terrain.heights > terrain.ditch_height
    starts = np.flatnonzero(solid & ~np.r_[False, solid[:-1]])
    ends = np.flatnonzero(solid & ~np.r_[solid[1:], False]) + 1
    if not starts.size:
        raise ValueError("the terrain has no solid ground to start on")
    first, last = terrain.x0 + float(starts[0]) * terrain.cell, terrain.x0 + float(ends[0]) * terrain.cell
    return first + leg if last - first > 2.0 * leg else 0.5 * (first + last)
