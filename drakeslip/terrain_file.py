"""Terrains from height-profile files, and terrains scaled to another hopper.

Two text forms are read (fields separated by commas, or by spaces when a row has no comma; blank lines and lines
starting with ``#`` are skipped, except that a comment may carry ``cell: C`` and ``x0: X``):

* **A profile**: rows ``x,height`` with x increasing; each height holds from its x to the next row's x, the last
  one for one cell. An optional first row of names (``x,height``) is skipped. The rows are resampled onto cells of
  ``cell`` [m]: the ``cell`` argument, else a ``# cell: C`` comment, else the smallest spacing of the rows (the
  shortest decimal, of at most 9 significant digits, within the float rounding of its two x values: rows at
  x = 9990.000 and 9990.001 are 1 mm apart, not 0.000999999998 m), which every row covers at least one cell of.
  The grid starts at the first row's x. A cell takes the highest height over it, and is a gap when any part of it
  is one (a hole anywhere in a cell makes it no foothold), so rows on the grid come out exactly and rows off it are
  never lost.
* **Heights per cell**: a comment ``# cell: 0.1, x0: -3`` (both keys, in any order) and then the heights of
  consecutive cells, any number per row; cell i covers ``[x0 + i cell, x0 + (i+1) cell)``. A ``cell`` argument
  other than the file's resamples it as above. ``save_terrain`` writes this form, one height per row.

A gap (ditch) is an empty field, ``-inf`` or ``nan``. Gap cells become a Terrain's ditches: they are put at
DITCH_HEIGHT (the paper's -1 m) when that is at least DITCH_DEPTH below every solid cell, else DITCH_DEPTH below
the lowest solid cell; ``ditch_height`` stays DITCH_HEIGHT while every solid cell is above it, else it is the ditch
floor. Either way exactly the gap cells are ditches, and the paper's terrains keep their -1 m ditches.
A malformed file raises one ValueError naming the file, the line and what is wrong. So does one outside the
bounds of ``drakeslip.bounds``, each checked before the work it bounds: the file's size (TERRAIN_FILE_BYTES, before
it is read), the numbers in its rows (TERRAIN_NUMBERS, as they are read), every x and x0, the end of the ground and
every height (POSITION: a run's start and goal on the ground are positions), the cell (CELL), and the cells the
rows are resampled onto (TERRAIN_CELLS, before they are made).
"""
from __future__ import annotations

import argparse
import math
import re
from pathlib import Path

import numpy as np

from drakeslip.bounds import CELL, POSITION, TERRAIN_CELLS, TERRAIN_FILE_BYTES, TERRAIN_NUMBERS
from drakeslip.jobs.files import atomic_write, first_line
from drakeslip.params import check_number, shown
from drakeslip.terrain import DITCH_HEIGHT, Terrain

DITCH_DEPTH = 0.5   # [m] a gap's floor lies at least this far below the lowest solid cell
HEADER_KEY = re.compile(r"\b(cell|x0)\s*:\s*([^,\s]*)")
OVERLAP_TOLERANCE = 1e-6   # of a cell: a row reaching into a cell by less than this does not count (rounding)


def terrain_with_gaps(heights, cell: float, x0: float) -> Terrain:
    """A Terrain from cell heights where NaN or -inf marks a gap: gaps become its ditches (see the module doc)."""
    h = np.array(heights, dtype=np.float64)
    gap = np.isnan(h) | (h == -math.inf)
    if h.ndim != 1 or gap.all():
        raise ValueError(f"a terrain needs a 1-D array of heights with at least one solid cell, got {h.size} "
                         f"value(s) of which {int(gap.sum())} are gaps")
    lowest = float(h[~gap].min())
    floor = min(DITCH_HEIGHT, lowest - DITCH_DEPTH)
    ditch_height = DITCH_HEIGHT if lowest > DITCH_HEIGHT else floor
    return Terrain(np.where(gap, floor, h), cell, x0, ditch_height)


def gaps_of(terrain: Terrain) -> np.ndarray:
    """The terrain's cell heights with its ditch cells as NaN."""
    return np.where(terrain.heights <= terrain.ditch_height, np.nan, terrain.heights)


def scaled_terrain(terrain: Terrain, length: float) -> Terrain:
    """The same ground for a hopper ``length`` times as long-legged (``HopperUnits.length``): every height, the
    cell size and x0 times ``length``, ditches kept ditches (floors as the module doc says). For ``length`` 1.0
    and a terrain whose ditches sit where that rule puts them (every generated family's) it is an equal Terrain."""
    length = check_number(length, "scaled_terrain length", positive=True)
    return terrain_with_gaps(gaps_of(terrain) * length, terrain.cell * length, terrain.x0 * length)


def load_terrain(path, cell: float | None = None) -> Terrain:
    """The terrain in a profile or heights-per-cell file (see the module doc), on cells of ``cell`` if given."""
    path = Path(path)
    if cell is not None:
        cell = check_number(cell, "terrain cell size", bound=CELL)
    where = f"terrain file {path}"
    size = path.stat().st_size
    if size > TERRAIN_FILE_BYTES:
        raise ValueError(f"{where} is {size / 2**20:.0f} MiB, more than a terrain file's "
                         f"{TERRAIN_FILE_BYTES / 2**20:.0f} MiB (drakeslip/bounds.py)")
    try:
        text = path.read_text()
    except UnicodeDecodeError as error:
        raise ValueError(f"{where} is not text: not UTF-8 ({error.reason} at byte {error.start})") from None
    header, rows = read_rows(text, where)
    if not rows:
        raise ValueError(f"{where} has no rows of heights")
    if "x0" in header:
        if "cell" not in header:
            raise ValueError(f"{where}, line {header['x0'][1]}: heights per cell need the cell size too "
                             f"('# cell: 0.1, x0: -3')")
        file_cell, x0 = header["cell"][0], header["x0"][0]
        heights = [height(field, n, where) for n, fields in rows for field in fields]
        check_cells(len(heights), file_cell, where)
        xs = x0 + file_cell * np.arange(len(heights))
        x_end = x0 + file_cell * len(heights)
        cell = cell or file_cell
    else:
        xs, heights = profile_rows(rows, where)
        cell = cell or (header["cell"][0] if "cell" in header else smallest_spacing(xs, rows, where))
        x_end = xs[-1] + cell
    if all(math.isnan(h) for h in heights):
        raise ValueError(f"{where}: no solid cell (every height is a gap)")
    if x_end > POSITION.high:
        raise ValueError(f"{where}: the ground ends at x = {x_end:.6g} m, beyond {POSITION}")
    check_cells(max(1, math.ceil((x_end - xs[0]) / cell - OVERLAP_TOLERANCE)), cell, where)
    return terrain_with_gaps(resample(np.asarray(xs), np.asarray(heights), x_end, cell), cell, float(xs[0]))


def check_cells(n: int, cell: float, where: str) -> None:
    """ValueError unless a map of ``n`` cells of ``cell`` m is within TERRAIN_CELLS (checked before it is made)."""
    if n > TERRAIN_CELLS:
        raise ValueError(f"{where} spans {n * cell:.6g} m: {n} cells of {cell:g} m, more than a terrain's "
                         f"{TERRAIN_CELLS} (drakeslip/bounds.py); give a coarser '# cell: C'")


def read_rows(text: str, where: str):
    """({key: (value, line)} from ``cell:``/``x0:`` comments, [(line, fields)] of the data rows), the first data
    row dropped when it is a row of names."""
    header, rows, names_possible, values = {}, [], True, 0
    for n, line in enumerate(text.splitlines(), 1):
        stripped = line.strip()
        if not stripped:
            continue
        if stripped.startswith("#"):
            for key, value in HEADER_KEY.findall(stripped):
                if key in header:
                    raise ValueError(f"{where}, line {n}: {key} is given twice (also on line {header[key][1]})")
                header[key] = (header_number(key, value, n, where), n)
            continue
        fields = [f.strip() for f in stripped.split(",")] if "," in stripped else stripped.split()
        if not (names_possible and all(f and not is_number(f) for f in fields)):
            rows.append((n, fields))
            values += len(fields)
            if values > TERRAIN_NUMBERS:
                raise ValueError(f"{where}, line {n}: the rows up to here hold more than {TERRAIN_NUMBERS} numbers "
                                 f"(drakeslip/bounds.py); give a coarser profile")
        names_possible = False
    return header, rows


def header_number(key: str, value: str, line: int, where: str) -> float:
    try:
        number = float(value)
    except ValueError:
        number = math.nan
    bound = CELL if key == "cell" else POSITION
    if not bound.low <= number <= bound.high:   # NaN compares False
        raise ValueError(f"{where}, line {line}: {key} must be a number in {bound}, got {shown(value)}")
    return number


def is_number(field: str) -> bool:
    try:
        float(field)
    except ValueError:
        return False
    return True


def height(field: str, line: int, where: str) -> float:
    """A height field: a finite number, or NaN for a gap (empty, -inf or nan)."""
    if field == "":
        return math.nan
    try:
        value = float(field)
    except ValueError:
        raise ValueError(f"{where}, line {line}: height {field!r} is not a number "
                         f"(a gap is an empty field, -inf or nan)") from None
    if value == math.inf:
        raise ValueError(f"{where}, line {line}: height {field!r} is not finite (a gap is -inf, nan or empty)")
    if abs(value) > POSITION.high and value != -math.inf:
        raise ValueError(f"{where}, line {line}: height must be a number in {POSITION} or a gap, got {shown(field)}")
    return math.nan if value == -math.inf else value


def profile_rows(rows, where: str):
    """(xs, heights) of ``x,height`` rows, x increasing."""
    xs, heights = [], []
    for n, fields in rows:
        if len(fields) != 2:
            raise ValueError(f"{where}, line {n}: a profile row is 'x,height', got {len(fields)} field(s) "
                             f"(heights per cell need a '# cell: C, x0: X' comment)")
        try:
            x = float(fields[0])
        except ValueError:
            x = math.nan
        if not POSITION.low <= x <= POSITION.high:   # NaN compares False
            raise ValueError(f"{where}, line {n}: x must be a number in {POSITION}, got {shown(fields[0])}")
        if xs and not x > xs[-1]:
            raise ValueError(f"{where}, line {n}: x={x:g} does not follow x={xs[-1]:g} (x must increase)")
        xs.append(x)
        heights.append(height(fields[1], n, where))
    return xs, heights


def smallest_spacing(xs, rows, where: str) -> float:
    """The smallest spacing of the rows' x values, as the module doc says: the shortest decimal of at most 9
    significant digits within twice the float spacing at the two x values (each x is the float nearest the decimal
    written, so their difference is off by up to that much), else the spacing to 9 digits. ValueError when it is
    below the smallest cell (CELL), naming the two rows."""
    if len(xs) < 2:
        raise ValueError(f"{where}: a one-row profile needs the cell size ('# cell: 0.1' or the cell argument)")
    k = int(np.argmin(np.diff(xs)))
    spacing = xs[k + 1] - xs[k]
    rounding = 2.0 * float(np.spacing(max(abs(xs[k]), abs(xs[k + 1]))))
    spacing = next((short for digits in range(1, 10) if abs((short := float(f"{spacing:.{digits}g}")) - spacing)
                    <= rounding), float(f"{spacing:.9g}"))
    if spacing < CELL.low:
        raise ValueError(f"{where}, lines {rows[k][0]} and {rows[k + 1][0]}: rows {spacing:g} m apart, closer than "
                         f"the smallest cell, {CELL.low:g} m (drakeslip/bounds.py); give '# cell: C' to resample "
                         f"them onto cells of C m")
    return spacing


def resample(xs: np.ndarray, heights: np.ndarray, x_end: float, cell: float) -> np.ndarray:
    """Cell heights on cells of ``cell`` from ``xs[0]``, of rows where row i holds ``heights[i]`` over
    ``[xs[i], xs[i+1])`` and the last row up to ``x_end``: the highest height over each cell, NaN where a gap
    reaches into it."""
    n = max(1, math.ceil((x_end - xs[0]) / cell - OVERLAP_TOLERANCE))
    edges = xs[0] + cell * np.arange(n + 1)
    tolerance = OVERLAP_TOLERANCE * cell
    first = np.searchsorted(xs, edges[:-1] + tolerance, side="right") - 1
    last = np.searchsorted(xs, edges[1:] - tolerance, side="left") - 1
    if np.array_equal(first, last):
        return heights[first]
    # the maximum over rows first..last of each cell at once (np.maximum keeps a NaN, a gap), from the bounds
    # interleaved: the reductions over [first, last + 1) are the even ones; one padding row keeps last + 1 in range
    bounds = np.column_stack([first, last + 1]).ravel()
    return np.maximum.reduceat(np.append(heights, 0.0), bounds)[::2]


def save_terrain(terrain: Terrain, path) -> None:
    """Write ``terrain`` in the heights-per-cell form, atomically: every float as Python writes it (so it reads
    back to the bit), ditch cells as -inf. Loading the file gives an equal Terrain when its ditch floors are where
    the module doc's rule puts them (the generated families', and every loaded terrain's)."""
    lines = ["# drakeslip terrain, heights per cell [m]; -inf is a gap (ditch)",
             f"# cell: {terrain.cell!r}, x0: {terrain.x0!r}"]
    lines += ["-inf" if math.isnan(h) else repr(float(h)) for h in gaps_of(terrain)]
    with atomic_write(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def terrain_argument(text: str) -> Terrain:
    """An argument type: a terrain file (a profile or heights per cell); a bad one is one line
    (argparse.ArgumentTypeError)."""
    path = Path(text)
    if not path.is_file():
        raise argparse.ArgumentTypeError(f"no such terrain file: {text!r}")
    try:
        return load_terrain(path)
    except (ValueError, OSError) as error:
        raise argparse.ArgumentTypeError(first_line(error)) from None
