"""Random height-map families for the spatial hopper: gaps, stepping stones, stairs, blocks and a course of them.

Every generator takes ``seed`` (each random choice comes from ``np.random.default_rng(seed)``), ``difficulty`` in
[0, 1] and ``length``, the hopper's leg length over the paper's 0.5 m. The ranges below are the paper's hopper's,
each written (easiest, hardest); every distance and height, the cell included, is multiplied by ``length``, so any
hopper gets the same suites in its own units. The difficulty rule: a feature's size is drawn from the half of its
range that the difficulty selects, ``easy + (hard - easy) * u`` with ``u`` uniform in [d/2, d/2 + 1/2]: difficulty 0
draws from the easier half, 1 from the harder half, and features still vary at every difficulty. Where things go
(which way an edge leans, how far aside a distractor is) is drawn uniformly at every difficulty.

A map covers x in [-3, 20) m and y in [-3, 3) m in 5 cm cells (origin (-3, -3)) and is flat at 0 for x < 1 m, so the
hopper starts on flat ground near (0, 0) and moves along +x. Each feature lies whole inside the map (an angled gap or
stair edge crosses its whole width), and the map ends with at least LANDING of ground, as the map extends flat.
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from drakeslip.bounds import Bound
from drakeslip.params import check_number
from drakeslip.spatial.heightmap import HeightMap
from drakeslip.terrain import check_names

X_START, X_END, HALF_WIDTH = -3.0, 20.0, 3.0   # [m] the map: x in [X_START, X_END), y in [-HALF_WIDTH, HALF_WIDTH)
CELL_SIZE = 0.05     # [m]
FLAT_UNTIL = 1.0     # [m] flat ground at 0 before this x: the start
LANDING = 0.6        # [m] ground after the last feature (and between a course's sections): a hop's landing
DIFFICULTY = Bound(0.0, 1.0)
EDGE_ANGLE = (0.0, 45.0)    # [deg] between an edge's normal (a gap's, a stair's) and the path (+x)
LEAN_FLIP = 0.3             # the chance that the next gap or flight of stairs leans the other way (a zig-zag)
GAP_WIDTH = (0.1, 1.0)      # [m] along the path (x), at every y
GAP_ISLAND = (1.5, 0.4)     # [m] ground between gaps along the path, at its narrowest across the map
STONE_SIZE = (0.6, 0.15)    # [m] a stone's length along x and width along y, each drawn
STONE_GAP = (0.1, 0.6)      # [m] edge to edge along the path from one stone to the next
STONE_JITTER = (0.0, 0.15)  # [m] a stone's height above or below the ground's level
STONE_OFFSET = (0.0, 0.3)   # [m] a path stone's centre to either side of the path's line (y = 0)
DISTRACTOR_CHANCE = 0.3     # the chance of a stone aside each path stone ...
DISTRACTOR_OFFSET = (0.7, 1.5)   # ... its centre this far [m] to either side of that stone's
STAIR_RISE = (0.05, 0.25)   # [m] up or down, in whole centimetres
STAIR_TREAD = (0.6, 0.3)    # [m] along the path, at its narrowest across the map
STAIR_LEVELS = (-0.3, 0.5)  # [m] stairs keep their levels in this band (as ``step_world`` does)
FLIGHT_STEPS = (2, 5)       # steps in a flight: parallel edges, one direction unless a level would leave the band
BLOCK_HEIGHT = (0.05, 0.25)  # [m] in whole centimetres
BLOCK_SIZE = (0.2, 1.0)     # [m] a box's length along x and width along y, each drawn
BLOCK_SPACING = (2.0, 0.6)  # [m] ground along the path between boxes on it
BLOCKS_ASIDE = (0, 3)       # boxes aside per box on the path: at least the first, fewer than the second
BLOCK_ASIDE = (0.3, 2.0)    # [m] from the path's line (y = 0) to an aside box's nearer side
SECTION_LENGTH = (3.0, 5.0)  # [m] a course's section along the path (a section holds at least one feature)

# The map being drawn, at the paper's hopper's scale: heights (ny, nx) and the cell centres' x and y (each (ny, nx))
Grid = namedtuple("Grid", ["h", "x", "y"])


def draw(rng, span, difficulty: float) -> float:
    """A size from ``span`` = (easiest, hardest): the part of the range that ``difficulty`` selects (module doc)."""
    easy, hard = span
    return easy + (hard - easy) * rng.uniform(difficulty / 2, difficulty / 2 + 0.5)


def cells(metres: float) -> int:
    """A length as whole cells, at least one."""
    return max(1, int(round(metres / CELL_SIZE)))


def column(x: float) -> int:
    """The index of the cell boundary nearest ``x`` along x."""
    return int(round((x - X_START) / CELL_SIZE))


def row(y: float) -> int:
    """The index of the cell boundary nearest ``y`` along y."""
    return int(round((y + HALF_WIDTH) / CELL_SIZE))


def new_grid() -> Grid:
    """Flat ground at 0 over the whole map."""
    nx, ny = cells(X_END - X_START), cells(2 * HALF_WIDTH)
    x, y = np.meshgrid(X_START + (np.arange(nx) + 0.5) * CELL_SIZE, -HALF_WIDTH + (np.arange(ny) + 0.5) * CELL_SIZE)
    return Grid(np.zeros((ny, nx)), x, y)


def slope(rng, difficulty: float, lean: float) -> float:
    """The x an edge moves per metre of y (``tan`` of its normal's angle to +x), leaning ``lean`` (+1 or -1)."""
    return lean * math.tan(math.radians(draw(rng, EDGE_ANGLE, difficulty)))


def fill_gaps(rng, difficulty: float, grid: Grid, start: float, stop: float, base: float) -> tuple:
    """Ground at ``base`` from ``start`` on, cut by gap bands (holes) that cross the map. Gaps follow while the
    next one's near edge at y = 0 is before ``stop`` (at least one is tried). Returns (the level after them, the x
    where the last one ends at the farthest); every section filler returns the same."""
    grid.h[:, column(start):] = base
    end = X_END - LANDING
    lean = rng.choice((-1.0, 1.0))
    far, far_slope, reached = start, 0.0, start   # the far edge of the last gap (at y = 0) and its slope
    while True:
        s = slope(rng, difficulty, lean)
        width = draw(rng, GAP_WIDTH, difficulty)
        # two edges of slopes a and b drift apart by |a - b| per metre of y: their gap at y = 0 is widened by that
        # across the half width, so the island stays GAP_ISLAND at its narrowest
        near = far + draw(rng, GAP_ISLAND, difficulty) + HALF_WIDTH * abs(s - far_slope)
        if (reached > start and near > stop) or near + width + HALF_WIDTH * abs(s) > end:
            return base, reached
        along = grid.x + grid.y * s   # where the edge through each cell centre meets y = 0
        grid.h[(along >= near) & (along < near + width)] = np.nan
        far, far_slope, reached = near + width, s, near + width + HALF_WIDTH * abs(s)
        lean = -lean if rng.uniform() < LEAN_FLIP else lean


def fill_stairs(rng, difficulty: float, grid: Grid, start: float, stop: float, base: float) -> tuple:
    """Flights of stairs from ``base``: each a few parallel edges that cross the map, the next flight's edges at
    another angle; levels stay in STAIR_LEVELS. See ``fill_gaps`` for ``stop`` and what is returned."""
    grid.h[:, column(start):] = base
    end = X_END - LANDING
    lean, level = rng.choice((-1.0, 1.0)), base
    edge, edge_slope, reached = start, 0.0, start
    while True:
        s = slope(rng, difficulty, lean)
        direction = rng.choice((-1.0, 1.0))
        for _ in range(rng.integers(FLIGHT_STEPS[0], FLIGHT_STEPS[1] + 1)):
            near = edge + draw(rng, STAIR_TREAD, difficulty) + HALF_WIDTH * abs(s - edge_slope)   # see fill_gaps
            if (reached > start and near > stop) or near + HALF_WIDTH * abs(s) > end:
                return level, reached
            rise = direction * round(draw(rng, STAIR_RISE, difficulty), 2)
            if not STAIR_LEVELS[0] <= level + rise <= STAIR_LEVELS[1]:
                direction, rise = -direction, -rise   # reflect at the band's edge so every rise keeps its size
            level = round(level + rise, 4)
            grid.h[grid.x + grid.y * s >= near] = level
            edge, edge_slope, reached = near, s, near + HALF_WIDTH * abs(s)
        lean = -lean if rng.uniform() < LEAN_FLIP else lean


def fill_stones(rng, difficulty: float, grid: Grid, start: float, stop: float, base: float) -> tuple:
    """Stepping stones over a hole from ``start``: a chain along the path, each within STONE_GAP of the last, and a
    few distractors aside. See ``fill_gaps`` for ``stop`` and what is returned; the ground after the last stone
    (at ``base``) is the next stone's distance on."""
    grid.h[:, column(start):] = base
    first, i, end = column(start), column(start), column(X_END - LANDING)
    middle = row(0.0)   # the row of y in [0, cell): the path's line
    path = []
    while True:
        gap, nx, ny = (cells(draw(rng, span, difficulty)) for span in (STONE_GAP, STONE_SIZE, STONE_SIZE))
        if (path and X_START + (i + gap) * CELL_SIZE > stop) or i + gap + nx > end:
            break
        offset = int(round(rng.choice((-1.0, 1.0)) * draw(rng, STONE_OFFSET, difficulty) / CELL_SIZE))
        path.append((i + gap, middle + offset - ny // 2, nx, ny))
        i += gap + nx
    holes = min(i + gap, end)
    grid.h[:, first:holes] = np.nan
    for i0, j0, nx, ny in path:
        grid.h[j0:j0 + ny, i0:i0 + nx] = base + stone_height(rng, difficulty)
    for i0, j0, nx, ny in path:
        if rng.uniform() < DISTRACTOR_CHANCE:
            place_distractor(rng, difficulty, grid, (i0 + nx // 2, j0 + ny // 2), (first, holes), base)
    return base, X_START + holes * CELL_SIZE


def stone_height(rng, difficulty: float) -> float:
    return rng.choice((-1.0, 1.0)) * round(draw(rng, STONE_JITTER, difficulty), 3)


def place_distractor(rng, difficulty: float, grid: Grid, beside: tuple, columns: tuple, base: float) -> None:
    """A stone to one side of the path stone centred on cell ``beside`` (column, row), within ``columns`` (the
    hole's first and end column), where a cell of hole stays all round it (else none)."""
    nx, ny = cells(draw(rng, STONE_SIZE, difficulty)), cells(draw(rng, STONE_SIZE, difficulty))
    i0 = beside[0] - nx // 2 + int(rng.integers(-nx // 2, nx // 2 + 1))
    j0 = beside[1] - ny // 2 + int(round(rng.choice((-1.0, 1.0)) * rng.uniform(*DISTRACTOR_OFFSET) / CELL_SIZE))
    ny_map, _ = grid.h.shape
    if i0 - 1 < columns[0] or i0 + nx + 1 > columns[1] or j0 < 1 or j0 + ny + 1 > ny_map:
        return
    if np.isnan(grid.h[j0 - 1:j0 + ny + 1, i0 - 1:i0 + nx + 1]).all():
        grid.h[j0:j0 + ny, i0:i0 + nx] = base + stone_height(rng, difficulty)


def fill_blocks(rng, difficulty: float, grid: Grid, start: float, stop: float, base: float) -> tuple:
    """Boxes on ground at ``base``: one on the path's line every BLOCK_SPACING or so (to go over or round) and a
    few aside. See ``fill_gaps`` for ``stop`` and what is returned."""
    grid.h[:, column(start):] = base
    i, end = column(start), column(X_END - LANDING)
    middle = row(0.0)
    reached = start
    while True:
        gap, nx, ny = (cells(draw(rng, span, difficulty)) for span in (BLOCK_SPACING, BLOCK_SIZE, BLOCK_SIZE))
        if (reached > start and X_START + (i + gap) * CELL_SIZE > stop) or i + gap + nx > end:
            return base, reached
        j0 = middle - int(rng.integers(1, max(2, ny)))   # it covers the path's line
        place_box(grid, (i + gap, j0, nx, ny), base + round(draw(rng, BLOCK_HEIGHT, difficulty), 2), base)
        for _ in range(rng.integers(*BLOCKS_ASIDE)):
            box = aside_box(rng, difficulty, (i, i + gap + nx), middle)
            if box[0] + box[2] <= i + gap + nx:   # it ends where the box on the path does: the next one is clear
                place_box(grid, box, base + round(draw(rng, BLOCK_HEIGHT, difficulty), 2), base)
        i += gap + nx
        reached = X_START + i * CELL_SIZE


def aside_box(rng, difficulty: float, columns: tuple, middle: int) -> tuple:
    """(first column, first row, columns, rows) of a box within ``columns`` (first, end) where it fits, clear of the
    path's line (row ``middle``) by BLOCK_ASIDE on a side drawn at random."""
    nx, ny = cells(draw(rng, BLOCK_SIZE, difficulty)), cells(draw(rng, BLOCK_SIZE, difficulty))
    clear = int(round(rng.uniform(*BLOCK_ASIDE) / CELL_SIZE))
    j0 = middle + 1 + clear if rng.uniform() < 0.5 else middle - clear - ny
    return int(rng.integers(columns[0], max(columns[0], columns[1] - nx) + 1)), j0, nx, ny


def place_box(grid: Grid, box: tuple, height: float, base: float) -> None:
    """Raise ``box`` (first column, first row, columns, rows) to ``height`` if it lies on the map and a cell of
    ground at ``base`` stays all round it (boxes never touch); else leave the map as it is."""
    i0, j0, nx, ny = box
    ny_map, nx_map = grid.h.shape
    if i0 < 1 or j0 < 1 or i0 + nx + 1 > nx_map or j0 + ny + 1 > ny_map:
        return
    if (grid.h[j0 - 1:j0 + ny + 1, i0 - 1:i0 + nx + 1] == base).all():
        grid.h[j0:j0 + ny, i0:i0 + nx] = height


SECTION_FILLERS = {"gaps": fill_gaps, "stones": fill_stones, "stairs": fill_stairs, "blocks": fill_blocks}


def check_difficulty(difficulty, length) -> tuple:
    """(difficulty, length) as floats if difficulty is in [0, 1] and length positive; else ValueError."""
    return (check_number(difficulty, "height map difficulty", bound=DIFFICULTY),
            check_number(length, "height map length (leg length / 0.5 m)", positive=True))


def scaled(grid: Grid, length: float) -> HeightMap:
    """The grid as a HeightMap for a hopper whose leg is ``length`` times the paper's."""
    return HeightMap(grid.h * length, CELL_SIZE * length, (X_START * length, -HALF_WIDTH * length))


def one_family(name: str, seed: int, difficulty: float, length: float) -> HeightMap:
    """A map of one family's features from FLAT_UNTIL to the end of the map."""
    difficulty, length = check_difficulty(difficulty, length)
    grid = new_grid()
    SECTION_FILLERS[name](np.random.default_rng(seed), difficulty, grid, FLAT_UNTIL, X_END, 0.0)
    return scaled(grid, length)


def gaps_map(seed: int, difficulty: float = 0.5, length: float = 1.0) -> HeightMap:
    """Ground at 0 cut by gaps (holes) GAP_WIDTH wide along the path whose edges lean EDGE_ANGLE, between islands
    at least GAP_ISLAND long at their narrowest; successive gaps at other angles and offsets."""
    return one_family("gaps", seed, difficulty, length)


def stones_map(seed: int, difficulty: float = 0.5, length: float = 1.0) -> HeightMap:
    """Stepping stones STONE_SIZE wide over a hole, STONE_GAP apart along the path, heights within STONE_JITTER of
    0, centres within STONE_OFFSET of the path's line, and a few distractor stones aside."""
    return one_family("stones", seed, difficulty, length)


def stairs_map(seed: int, difficulty: float = 0.5, length: float = 1.0) -> HeightMap:
    """Flights of stairs up and down, rises STAIR_RISE, treads STAIR_TREAD, edges leaning EDGE_ANGLE, levels
    within STAIR_LEVELS."""
    return one_family("stairs", seed, difficulty, length)


def blocks_map(seed: int, difficulty: float = 0.5, length: float = 1.0) -> HeightMap:
    """Boxes BLOCK_HEIGHT high with footprints of BLOCK_SIZE on ground at 0: on the path's line and aside."""
    return one_family("blocks", seed, difficulty, length)


def course_map(seed: int, difficulty: float = 0.5, length: float = 1.0) -> HeightMap:
    """Sections of SECTION_LENGTH along the path, each of another family than the one before (gaps, stones,
    stairs, blocks), LANDING of ground between them; a section's ground is at the level the one before ends on."""
    difficulty, length = check_difficulty(difficulty, length)
    rng = np.random.default_rng(seed)
    grid = new_grid()
    start, level, previous = FLAT_UNTIL, 0.0, None
    while start < X_END - LANDING - SECTION_LENGTH[0]:
        name = rng.choice(sorted(set(SECTION_FILLERS) - {previous}))
        stop = start + rng.uniform(*SECTION_LENGTH)
        level, reached = SECTION_FILLERS[name](rng, difficulty, grid, start, stop, level)
        start, previous = reached + LANDING, name
    return scaled(grid, length)


HEIGHT_MAP_FAMILIES = {"gaps": gaps_map, "stones": stones_map, "stairs": stairs_map, "blocks": blocks_map,
                       "course": course_map}


def check_height_map_families(names) -> tuple:
    """``names`` as a tuple when it lists one or more families of ``HEIGHT_MAP_FAMILIES``; else a ValueError naming
    the unknown ones and the known families."""
    return check_names(names, HEIGHT_MAP_FAMILIES, "height map families")


def height_map_family(name: str):
    """The generator of the height map family ``name`` (``height_map_family("gaps")(seed)`` is ``gaps_map(seed)``);
    a ValueError naming the known families for any other name."""
    return HEIGHT_MAP_FAMILIES[check_height_map_families([name])[0]]
