"""The physical bounds of every input, in one place: the hopper's parameters, its apex, goals, terrain cells and
heights. ``drakeslip.params.check_number(value, name, bound=...)`` checks a value against one and names the
field and the bound when it is outside; the suite and plan readers, ``SlipParams``, ``ApexState``, ``Terrain``
and the planners' ``plan`` check every input this way, so a bad one is refused before any work starts.

Why these numbers: each lies far outside any real hopper, so no real input is refused (hoppers of 3-30 kg with
legs of 0.3-1.2 m, dimensionless stiffness k L0 / (m g) of 10-40, friction 0.6-1.0, terrain maps of 1 cm to
1 m cells, speeds of a few m/s), and each keeps the work of a call finite and small: a 1e308 m/s apex would size
a planner's candidate footholds by its reach (terabytes), a 1e-9 m cell a perception window of 1e10 cells, and
a 1e308 stiffness or gravity overflows the integrator.

A start apex a user gives (a suite's or a plan file's, the scripts' --height and --speed:
``drakeslip.state.check_start``) also lies within two bounds in the hopper's own units, the units of
``drakeslip.units`` (lengths in leg lengths L0, speeds in sqrt(g L0)), as what the code does depends on them:

* APEX_HEIGHT: at most 10 leg lengths above the ground under it (5 m for the paper's hopper). A hopper of the range
  above survives a drop of at most about 3 leg lengths (a spring of k L0 / (m g) = 40 compressed by 40 % of the
  leg stores 3.2 body weights times L0), so no start a hopper lives through is refused.
* APEX_SPEED: at most 5 sqrt(g L0) forward or back (11 m/s for the paper's hopper; a Froude number v^2 / (g L0)
  of 25, 2.5 times a human sprinter's; the suites' fastest start, 3 m/s, is 1.35 sqrt(g L0)).

Together they keep the energy height z + xdot^2 / (2 g) within 22.5 leg lengths of the ground, which sizes the
two things that grow with it: the cell graph of the energy argument (``planners.search.energy_graph``) spans
twice that height ahead of the start (a 1e4 m apex asked for a 298 GiB matrix), and a hop's flights take up to
2 sqrt(2 x 22.5) = 13.4 time units sqrt(L0 / g), inside the Drake simulators' per-hop limit of 22 units
(``drakeslip.units.HOP_SECONDS``, 5 s for the paper's hopper). An apex reached during a run is not checked
against them (a hop over a step down is higher above the ground under it than its start): the code stays right
there, within the bounds above, by itself (the cell graph refuses more than ``MAX_CELLS`` cells, and the planners
then skip the stage that needs it; a hop past the limit is a TIMEOUT, not a physical failure).
"""
from __future__ import annotations

from typing import NamedTuple


class Bound(NamedTuple):
    """A closed interval [low, high] in ``unit``."""

    low: float
    high: float
    unit: str = ""

    def __str__(self) -> str:
        return f"[{self.low:g}, {self.high:g}]" + (f" {self.unit}" if self.unit else "")


MASS = Bound(1e-3, 1e4, "kg")              # a gram to ten tonnes
LEG_LENGTH = Bound(1e-2, 10.0, "m")        # spring rest length: a centimetre to ten metres
STIFFNESS = Bound(1e-2, 1e9, "N/m")        # the hoppers above: 250-40,000 N/m
GRAVITY = Bound(0.1, 100.0, "m/s^2")       # a tenth of the Moon's to ten times the Earth's
FRICTION = Bound(1e-3, 10.0)               # Coulomb coefficient: far below ice's, far above rubber on rock's
SPEED = Bound(-50.0, 50.0, "m/s")          # apex xdot: ten times a fast legged robot's
POSITION = Bound(-1e4, 1e4, "m")           # x and z of an apex, a foothold, a goal; terrain heights
# A terrain's first cell may lie further out than any body: a perception window starts behind the body, and a
# map may start anywhere before the ground a run uses.
TERRAIN_START = Bound(-1e5, 1e5, "m")
CELL = Bound(1e-3, 10.0, "m")              # a millimetre to ten metres
HORIZON = Bound(0.0, 1e3, "m")             # how far ahead of the body a planner plans: its grids grow with it
# A start apex, in the hopper's units (the module doc): its height above the ground under it, in leg lengths, and
# its forward speed, in sqrt(g L0)
APEX_HEIGHT = Bound(0.0, 10.0, "leg lengths")
APEX_SPEED = Bound(-5.0, 5.0, "sqrt(g L0)")
# The most cells a perception window holds: an 11 m window of 1 mm cells has 11,000; a window of more cells than
# this comes from a window size no robot perceives.
MAX_WINDOW_CELLS = 1_000_000
# A terrain file (drakeslip/terrain_file.py) is read whole, number by number in Python (about a microsecond each),
# and resampled onto cells: these keep that to about a second and tens of MB, each checked before the work it
# bounds. 400,000 numbers are a profile of 200,000 x,height rows (200 m at 1 mm, 20 km at 10 cm; the paper's maps
# have 150 cells), about 8 MB at full precision. A million cells of 1 mm are a kilometre.
TERRAIN_FILE_BYTES = 16 * 2**20            # the file's size, checked before it is read
TERRAIN_NUMBERS = 400_000                  # the numbers (x values and heights) of its rows, counted as they are read
TERRAIN_CELLS = 1_000_000                  # cells of the map the rows are resampled onto
# A height map (drakeslip/spatial/heightmap.py) is held whole in memory and read cell by cell by the compiled step
# map: 4 million cells (32 MB) are a 2 km x 2 km DEM at 1 m, or 100 m x 100 m at 5 cm; a map of more cells comes
# from a cell size no robot's map uses. Its file (.npz) is read only up to HEIGHT_MAP_FILE_BYTES.
HEIGHT_MAP_CELLS = 4_000_000
HEIGHT_MAP_FILE_BYTES = 64 * 2**20
