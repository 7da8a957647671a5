"""Height maps: the ground of the spatial hopper, a 2.5D grid of cell heights with holes.

Cell [j, i] of ``heights`` (ny rows along y, nx columns along x) covers x in [x0 + i cell, x0 + (i+1) cell) and
y in [y0 + j cell, y0 + (j+1) cell) at its height; ``origin`` = (x0, y0) is the corner of cell [0, 0]. A hole
(NaN, or -inf) is no foothold: a foot that reaches one is a FOOT_COLLISION, as a ditch is in the planar terrain.
Beyond its edges a map extends flat, each edge cell outwards (as a planar ``Terrain`` does).

A file is a NumPy ``.npz`` with ``heights`` (ny x nx, metres, NaN = hole), ``cell`` (m) and ``origin`` (x0, y0),
or an ESRI ASCII grid (``.asc``: ``ncols``, ``nrows``, ``xllcorner``, ``yllcorner``, ``cellsize``,
``NODATA_value`` and rows from north to south), the format GIS tools export a DEM patch in. Everything is checked
before any work: the shape, the cell (``drakeslip.bounds.CELL``), the origin (TERRAIN_START), every height
(POSITION), the number of cells (HEIGHT_MAP_CELLS; a ``.npz``'s as its headers declare it, before any array is
read) and a file's size (HEIGHT_MAP_FILE_BYTES); a bad value is a ValueError of one line naming it.
"""
from __future__ import annotations

import math
import zipfile
import zlib
from collections import namedtuple
from pathlib import Path

import numpy as np

from drakeslip.bounds import CELL, HEIGHT_MAP_CELLS, HEIGHT_MAP_FILE_BYTES, POSITION, TERRAIN_START
from drakeslip.jobs.files import atomic_write
from drakeslip.params import check_number, shown
from drakeslip.terrain import DITCH_HEIGHT
from drakeslip.terrain_file import DITCH_DEPTH

# A height map as compiled code reads it: solid heights with holes at ``ditch_height`` or below, cells of ``cell``
# from (x0, y0), and the lowest solid height (how far a flight can fall at most).
Ground3 = namedtuple("Ground3", ["heights", "x0", "y0", "cell", "ditch_height", "lowest"])


class HeightMap:
    """A grid of cell heights over the plane, holes as NaN (see the module doc).

    ``heights`` (ny, nx) [m]; ``cell`` [m]; ``origin`` (x0, y0) [m], the corner of cell [0, 0]. ``extends_flat``
    False marks a perception window: nothing is known past its edges (``contains`` says what is).
    """

    def __init__(self, heights, cell: float = 0.1, origin=(0.0, 0.0), extends_flat: bool = True):
        h = check_heights(heights)
        self.cell = check_number(cell, "height map cell", bound=CELL)
        self.origin = check_origin(origin)
        self.extends_flat = bool(extends_flat)
        gap = np.isnan(h)
        lowest = float(h[~gap].min())
        # holes sit below every solid cell, at the planar terrain's ditch floor where that is low enough
        self.ditch_height = DITCH_HEIGHT if lowest > DITCH_HEIGHT else lowest - DITCH_DEPTH
        floor = min(DITCH_HEIGHT, lowest - DITCH_DEPTH)
        self.solid = np.where(gap, floor, h)
        self.solid.setflags(write=False)
        self.heights = h
        self.heights.setflags(write=False)
        self._ground = Ground3(self.solid, self.origin[0], self.origin[1], self.cell, self.ditch_height, lowest)

    @property
    def shape(self) -> tuple:
        return self.heights.shape

    def ground(self) -> Ground3:
        """This map as compiled code reads it."""
        return self._ground

    @property
    def extent(self) -> tuple:
        """(x_min, x_max, y_min, y_max) of the cells."""
        ny, nx = self.heights.shape
        x0, y0 = self.origin
        return x0, x0 + nx * self.cell, y0, y0 + ny * self.cell

    def index(self, x, y):
        """(row j, column i) of the cells under (x, y), clamped to the edges, where the map extends flat."""
        ny, nx = self.heights.shape
        i = np.floor((np.asarray(x, dtype=np.float64) - self.origin[0]) / self.cell).astype(np.int64)
        j = np.floor((np.asarray(y, dtype=np.float64) - self.origin[1]) / self.cell).astype(np.int64)
        return np.minimum(np.maximum(j, 0), ny - 1), np.minimum(np.maximum(i, 0), nx - 1)

    def height_at(self, x, y):
        """The height under (x, y), NaN over a hole (a float for one point, else an array)."""
        h = self.heights[self.index(x, y)]
        return float(h) if np.ndim(h) == 0 else h

    def is_hole_at(self, x, y):
        return np.isnan(self.height_at(x, y))

    def contains(self, x, y):
        """Whether (x, y) lies on the map's cells (a map extends flat everywhere, a window only over its cells)."""
        if self.extends_flat:
            return np.ones(np.shape(np.asarray(x) + np.asarray(y)), dtype=bool) if np.ndim(x) else True
        x_min, x_max, y_min, y_max = self.extent
        return (x_min <= np.asarray(x)) & (np.asarray(x) < x_max) & (y_min <= np.asarray(y)) & (np.asarray(y) < y_max)

    def rotated90(self, turns: int = 1) -> "HeightMap":
        """This map turned ``turns`` quarter turns anticlockwise about the world's origin (for checks that the
        physics does not depend on the heading)."""
        h, (x0, y0), c = self.heights, self.origin, self.cell
        ny, nx = h.shape
        for _ in range(turns % 4):
            # (x, y) -> (-y, x): the new x axis runs along the old y, from -(y0 + ny c)
            h, (x0, y0) = np.flipud(h).T, (-(y0 + ny * c), x0)
            ny, nx = h.shape
        return HeightMap(h, c, (x0, y0), self.extends_flat)

    def window(self, x_min: float, x_max: float, y_min: float, y_max: float) -> "HeightMap":
        """The cells over [x_min, x_max] x [y_min, y_max] as a map of their own, known only over its cells
        (``extends_flat=False``: a perception window); cells past this map's edges read its edge cells."""
        c, (x0, y0) = self.cell, self.origin
        i0, i1 = math.floor((x_min - x0) / c), math.floor((x_max - x0) / c) + 1
        j0, j1 = math.floor((y_min - y0) / c), math.floor((y_max - y0) / c) + 1
        if (i1 - i0) * (j1 - j0) > HEIGHT_MAP_CELLS:
            raise ValueError(f"a window of {x_max - x_min:g} m x {y_max - y_min:g} m in {c:g} m cells has "
                             f"{(i1 - i0) * (j1 - j0)} cells, more than the {HEIGHT_MAP_CELLS} a map may hold")
        ny, nx = self.heights.shape
        rows = np.clip(np.arange(j0, j1), 0, ny - 1)
        cols = np.clip(np.arange(i0, i1), 0, nx - 1)
        return HeightMap(self.heights[np.ix_(rows, cols)], c, (x0 + i0 * c, y0 + j0 * c), extends_flat=False)

    def perceived(self, x: float, y: float, heading, ahead: float, aside: float, behind: float) -> "HeightMap":
        """What the hopper at (x, y) facing ``heading`` (a horizontal direction) sees: the window over the cells of
        the rectangle ``behind`` .. ``ahead`` along the heading and ``aside`` to either side of it [m] (the axis-aligned
        cells that cover it)."""
        hx, hy = heading
        norm = math.hypot(hx, hy)
        hx, hy = (hx / norm, hy / norm) if norm > 0 else (1.0, 0.0)
        corners = [(x + a * hx - s * hy, y + a * hy + s * hx) for a in (-behind, ahead) for s in (-aside, aside)]
        xs, ys = [p[0] for p in corners], [p[1] for p in corners]
        return self.window(min(xs), max(xs), min(ys), max(ys))

    def save(self, path) -> None:
        """Write the map as ``.npz`` (heights, cell, origin), atomically."""
        with atomic_write(path) as f:
            np.savez_compressed(f, heights=self.heights, cell=self.cell, origin=np.array(self.origin))

    @classmethod
    def flat(cls, height: float = 0.0, cell: float = 0.1, origin=(-3.0, -3.0), size=(30.0, 6.0)) -> "HeightMap":
        nx, ny = (max(1, int(round(s / cell))) for s in size)
        return cls(np.full((ny, nx), float(height)), cell, origin)

    @classmethod
    def from_profile(cls, terrain, y_min: float = -2.0, y_max: float = 2.0) -> "HeightMap":
        """A planar ``Terrain`` extruded across the path over y in [y_min, y_max): every row is its profile, its
        ditches holes."""
        profile = np.where(terrain.heights <= terrain.ditch_height, np.nan, terrain.heights)
        rows = max(1, int(round((y_max - y_min) / terrain.cell)))
        return cls(np.tile(profile, (rows, 1)), terrain.cell, (terrain.x0, y_min))

    def __repr__(self):
        window = "" if self.extends_flat else ", extends_flat=False"
        return f"HeightMap(shape={self.heights.shape}, cell={self.cell}, origin={self.origin}{window})"


def check_heights(heights) -> np.ndarray:
    """``heights`` as a new float (ny, nx) array with holes as NaN (-inf is a hole too), if it is 2-D, at most
    HEIGHT_MAP_CELLS cells, has a solid cell and every solid height is inside POSITION; else ValueError."""
    shape = np.shape(heights) if isinstance(heights, np.ndarray) else None
    if shape is not None and (len(shape) != 2 or 0 in shape):
        raise ValueError(f"height map heights must be a 2-D (ny, nx) array with at least one cell, got shape {shape}")
    if shape is not None and shape[0] * shape[1] > HEIGHT_MAP_CELLS:
        raise ValueError(f"height map of {shape[0]} x {shape[1]} cells is more than the {HEIGHT_MAP_CELLS} a map may "
                         "hold (HEIGHT_MAP_CELLS of drakeslip/bounds.py)")
    try:
        h = np.array(heights, dtype=np.float64)
    except (OverflowError, TypeError, ValueError):
        raise ValueError(f"height map heights must be a 2-D array of numbers, got {shown(heights)}") from None
    if h.ndim != 2 or h.size == 0:
        raise ValueError(f"height map heights must be a 2-D (ny, nx) array with at least one cell, got shape {h.shape}")
    if h.size > HEIGHT_MAP_CELLS:
        raise ValueError(f"height map of {h.shape[0]} x {h.shape[1]} cells is more than the {HEIGHT_MAP_CELLS} a map "
                         "may hold (HEIGHT_MAP_CELLS of drakeslip/bounds.py)")
    h[h == -math.inf] = math.nan
    solid = ~np.isnan(h)
    if not solid.any():
        raise ValueError(f"height map of {h.shape[0]} x {h.shape[1]} cells has no solid cell (every height is a hole)")
    bad = np.argwhere(solid & ~(np.abs(h) <= POSITION.high))
    if bad.size:
        j, i = bad[0]
        check_number(h[j, i], f"height map heights[{j}, {i}]", bound=POSITION)
    return h


def check_origin(origin) -> tuple:
    """``origin`` as (x0, y0) floats inside TERRAIN_START; else ValueError naming it."""
    try:
        x0, y0 = origin
    except (TypeError, ValueError):
        raise ValueError(f"height map origin must be (x0, y0), got {shown(origin)}") from None
    return (check_number(x0, "height map origin x0", bound=TERRAIN_START),
            check_number(y0, "height map origin y0", bound=TERRAIN_START))


MAP_SUFFIXES = (".npz", ".asc")   # height-map files (``load_height_map``); every other terrain file is a profile


def load_height_map(path) -> HeightMap:
    """The height map in ``path``: ``.npz`` (heights, cell, origin) or an ESRI ASCII grid ``.asc`` (module doc)."""
    path = Path(path)
    where = f"height map file {path}"
    try:
        size = path.stat().st_size
    except OSError as error:
        raise ValueError(f"{where}: cannot be read ({error.strerror})") from None
    if size > HEIGHT_MAP_FILE_BYTES:
        raise ValueError(f"{where} is {size} bytes, more than the {HEIGHT_MAP_FILE_BYTES} a height map file may be "
                         "(HEIGHT_MAP_FILE_BYTES of drakeslip/bounds.py)")
    try:
        if path.suffix.lower() == ".asc":
            return read_ascii_grid(path.read_text(), where)
        return read_npz(path, where)
    except ValueError as error:
        message = str(error)
        raise ValueError(message if message.startswith(where) else f"{where}: {message}") from None


NPZ_KEYS = ("heights", "cell", "origin")
NPY_HEADER_READERS = {(1, 0): np.lib.format.read_array_header_1_0, (2, 0): np.lib.format.read_array_header_2_0}


def read_npz(path: Path, where: str) -> HeightMap:
    """The map of an ``.npz``; the shape and dtype each array's ``.npy`` header declares are checked before any
    array is read, as loading allocates the declared shape whatever the file holds (a header of a few bytes may
    declare 10^10 cells, 64 MB of compressed zeros may decompress to gigabytes)."""
    try:
        with zipfile.ZipFile(path) as archive:
            members = set(archive.namelist())
            # np.load reads the member named as the key before the one named key.npy
            names = {key: key if key in members else f"{key}.npy" for key in NPZ_KEYS}
            headers = {key: npy_header(archive, name) for key, name in names.items() if name in members}
    # RuntimeError: an encrypted member; its NotImplementedError: a compression zipfile does not read
    except (OSError, EOFError, ValueError, RuntimeError, zipfile.BadZipFile, zlib.error) as error:
        raise ValueError(f"{where} is not a readable .npz file ({error})") from None
    missing = [key for key in NPZ_KEYS if key not in headers]
    if missing:
        raise ValueError(f"{where} lacks {', '.join(missing)} (it needs heights, cell and origin)")
    check_npz_headers(headers, where)
    try:
        with np.load(path, allow_pickle=False) as data:
            heights, cell, origin = data["heights"], data["cell"], data["origin"]
    except (OSError, EOFError, ValueError, zipfile.BadZipFile, zlib.error) as error:
        raise ValueError(f"{where} is not a readable .npz file ({error})") from None
    return HeightMap(heights, float(cell.reshape(-1)[0]), (float(origin[0]), float(origin[1])))


def npy_header(archive: zipfile.ZipFile, member: str) -> tuple:
    """(shape, dtype) as the ``.npy`` header of ``member`` declares them, read without the array; ValueError for a
    member that is no ``.npy`` of a version numpy writes numbers in (3.0 is only for structured dtypes)."""
    with archive.open(member) as stream:
        version = np.lib.format.read_magic(stream)
        if version not in NPY_HEADER_READERS:
            raise ValueError(f"{member} is a .npy of version {version[0]}.{version[1]}, not 1.0 or 2.0")
        shape, _, dtype = NPY_HEADER_READERS[version](stream)
    return shape, dtype


def check_npz_headers(headers: dict, where: str) -> None:
    """A ValueError of one line naming ``where`` unless ``headers`` ({key: (shape, dtype)}) declare number arrays:
    heights 2-D of 1 to HEIGHT_MAP_CELLS cells, cell one number and origin two."""
    for key, (shape, dtype) in headers.items():
        if dtype.kind not in "fiu":   # no objects (pickles), strings, booleans, complex or records
            raise ValueError(f"{where}: {key} must be numbers, got dtype {dtype}")
    shape = headers["heights"][0]
    if len(shape) != 2 or min(shape) < 1:
        raise ValueError(f"{where}: heights must be a 2-D (ny, nx) array with at least one cell, got shape {shape}")
    if shape[0] * shape[1] > HEIGHT_MAP_CELLS:
        raise ValueError(f"{where}: its heights declare {shape[0]} x {shape[1]} cells, more than the "
                         f"{HEIGHT_MAP_CELLS} cells a map may hold (HEIGHT_MAP_CELLS of drakeslip/bounds.py)")
    if math.prod(headers["cell"][0]) != 1:
        raise ValueError(f"{where}: cell must be one number, got shape {headers['cell'][0]}")
    if headers["origin"][0] != (2,):
        raise ValueError(f"{where}: origin must be (x0, y0), got shape {headers['origin'][0]}")


ASCII_KEYS = ("ncols", "nrows", "xllcorner", "yllcorner", "cellsize")


def read_ascii_grid(text: str, where: str) -> HeightMap:
    """An ESRI ASCII grid: a header of ``key value`` lines, then nrows rows of ncols heights, north row first."""
    lines = [line.split() for line in text.splitlines() if line.strip()]
    header = {}
    while lines and lines[0] and lines[0][0].lower() in (*ASCII_KEYS, "nodata_value", "xllcenter", "yllcenter"):
        key, *value = lines.pop(0)
        if len(value) != 1:
            raise ValueError(f"{where}: header line {key!r} needs one value")
        if key.lower() in header:   # two values of one key: which the exporter meant is not for the reader to pick
            raise ValueError(f"{where}: header line {key!r} is given twice")
        header[key.lower()] = value[0]
    if "xllcenter" in header or "yllcenter" in header:
        raise ValueError(f"{where}: xllcenter/yllcenter grids are not read; give xllcorner and yllcorner")
    missing = [key for key in ASCII_KEYS if key not in header]
    if missing:
        raise ValueError(f"{where}: header lacks {', '.join(missing)}")
    try:
        nx, ny = int(header["ncols"]), int(header["nrows"])
        x0, y0, cell = (float(header[k]) for k in ("xllcorner", "yllcorner", "cellsize"))
        nodata = float(header.get("nodata_value", "nan"))
    except ValueError:
        raise ValueError(f"{where}: header values must be numbers ({header})") from None
    if nx < 1 or ny < 1 or nx * ny > HEIGHT_MAP_CELLS:
        raise ValueError(f"{where}: a grid of {ny} x {nx} cells; a map holds 1 to {HEIGHT_MAP_CELLS} cells")
    if len(lines) != ny or any(len(row) != nx for row in lines):
        raise ValueError(f"{where}: expected {ny} rows of {nx} heights after the header")
    try:
        h = np.array(lines, dtype=np.float64)[::-1]   # the file's first row is the north (largest y) one
    except ValueError:
        raise ValueError(f"{where}: a height is not a number") from None
    h[h == nodata] = math.nan
    return HeightMap(h, check_number(cell, f"{where}: cellsize", bound=CELL), (x0, y0))


def merge_cells(heights) -> list[tuple]:
    """Rectangles (j0, j1, i0, i1, height) covering the solid (non-NaN) cells of ``heights`` (ny, nx) exactly,
    each of cells of one height: the runs of equal cells along each row (x), then each run joined with the same
    run (same columns, same height) in the rows after it."""
    heights = np.asarray(heights, dtype=float)
    open_runs, done = {}, []
    for j, row in enumerate(heights):
        runs, start = set(), 0
        for i in range(1, row.size + 1):
            if i == row.size or not (row[i] == row[start]):  # NaN != NaN: a hole ends a run and makes none
                if not math.isnan(row[start]):
                    runs.add((start, i, float(row[start])))
                start = i
        for key in set(open_runs) - runs:  # a run that does not go on closes
            done.append((open_runs.pop(key), j, key[0], key[1], key[2]))
        for key in runs - set(open_runs):
            open_runs[key] = j
    done += [(j0, heights.shape[0], i0, i1, h) for (i0, i1, h), j0 in open_runs.items()]
    return sorted(done)


class ScalarHeights:
    """A height map's height (NaN over a hole) at a scalar (x, y), in plain Python, as ``HeightMap.height_at`` reads
    it (clamped to the edges): read at every step of a robot's run, where numpy's call costs more than the lookup."""

    def __init__(self, height_map: HeightMap):
        self.rows = height_map.heights.tolist()
        self.x0, self.y0 = height_map.origin
        self.cell = height_map.cell
        self.ny, self.nx = height_map.shape

    def __call__(self, x: float, y: float) -> float:
        i = min(max(int(math.floor((x - self.x0) / self.cell)), 0), self.nx - 1)
        j = min(max(int(math.floor((y - self.y0) / self.cell)), 0), self.ny - 1)
        return self.rows[j][i]

    def highest_along(self, start, end) -> float:
        """The highest solid cell under the segment from ``start`` to ``end`` ((x, y) each), sampled every half cell
        (a hole counts as no ground; -inf under holes only)."""
        steps = max(1, int(math.ceil(2.0 * math.hypot(end[0] - start[0], end[1] - start[1]) / self.cell)))
        highest = -math.inf
        for k in range(steps + 1):
            h = self(start[0] + (end[0] - start[0]) * k / steps, start[1] + (end[1] - start[1]) * k / steps)
            if h > highest:   # False for NaN
                highest = h
        return highest
