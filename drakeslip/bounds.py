"""The physical bounds of every input, in one place: the hopper's parameters, its apex, goals, terrain cells and
heights. ``drakeslip.params.check_number(value, name, bound=...)`` checks a value against one and names the
field and the bound when it is outside; the suite and plan readers, ``SlipParams``, ``ApexState``, ``Terrain``
and the planners' ``plan`` check every input this way, so a bad one is refused before any work starts.

Why these numbers: each lies far outside any real hopper, so no real input is refused (hoppers of 3-30 kg with
legs of 0.3-1.2 m, dimensionless stiffness k L0 / (m g) of 10-40, friction 0.6-1.0, terrain maps of 1 cm to
1 m cells, speeds of a few m/s), and each keeps the work of a call finite and small: a 1e308 m/s apex would size
a planner's candidate footholds by its reach (terabytes), a 1e-9 m cell a perception window of 1e10 cells, and
a 1e308 stiffness or gravity overflows the integrator.
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
