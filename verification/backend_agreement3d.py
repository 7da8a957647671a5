"""Do the spatial step maps agree? Random hops on the height-map families, compiled against Drake, case by case
(``verification.backend_agreement`` in three dimensions; its ``AgreementReport`` sums them up)."""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from drakeslip.params import SlipParams
from drakeslip.spatial.families import check_height_map_families, height_map_family
from drakeslip.spatial.heightmap import HeightMap
from drakeslip.spatial.state import StepResult3D
from drakeslip.spatial.stepmap import step3d
from drakeslip.units import units_of
from verification.backend_agreement import AgreementReport, compare


@dataclass(frozen=True)
class Case3D:
    """One random hop: the map's family, seed, difficulty and length scale (the hopper's leg over the paper's), the
    apex (x, y, z, xdot, ydot), the leg (pitch, roll)."""

    family: str
    map_seed: int
    difficulty: float
    length: float
    apex: tuple
    leg_angles: tuple

    def height_map(self) -> HeightMap:
        return map_of(self.family, self.map_seed, self.difficulty, self.length)


@functools.lru_cache(maxsize=8)
def map_of(family: str, seed: int, difficulty: float, length: float) -> HeightMap:
    return height_map_family(family)(seed, difficulty, length)


@dataclass(frozen=True)
class Comparison3D:
    case: Case3D
    fast: StepResult3D
    drake: StepResult3D

    @property
    def same_outcome(self) -> bool:
        """The same failure (or none), and where both touched down, in the same cell of the map: a foot that clips a
        cell's corner for less than one integrator step lands there on the compiled map, which finds every crossing,
        and flies on past it on Drake, whose guards see only the step's ends; that is another touchdown, not a
        deviation."""
        if self.fast.failure != self.drake.failure:
            return False
        fast, drake = self.fast.foothold, self.drake.foothold
        if math.isnan(fast[0]) or math.isnan(drake[0]):
            return math.isnan(fast[0]) == math.isnan(drake[0])
        return self.case.height_map().index(fast[0], fast[1]) == self.case.height_map().index(drake[0], drake[1])

    @property
    def both_ok(self) -> bool:
        return self.fast.ok and self.drake.ok and self.same_outcome

    def largest(self, fast, drake) -> float:
        return max(abs(a - b) for a, b in zip(fast, drake)) if self.both_ok else math.nan

    @property
    def touchdown_deviation(self) -> float:
        """Largest |fast - drake| of the foothold's x, y, z [m] (both ok only, else NaN)."""
        return self.largest(self.fast.foothold, self.drake.foothold)

    @property
    def apex_deviation(self) -> float:
        """Largest |fast - drake| of the next apex's x, y, z [m] (both ok only, else NaN)."""
        return self.largest(self.fast.end_state[:3], self.drake.end_state[:3])

    @property
    def speed_deviation(self) -> float:
        """Largest |fast - drake| of the next apex's xdot, ydot [m/s] (both ok only, else NaN)."""
        return self.largest(self.fast.end_state[3:5], self.drake.end_state[3:5])

    def describe(self) -> str:
        c = self.case

        def outcome(r):
            name = "ok" if r.ok else r.failure.name
            return f"{name} at t={r.time:.4f} ({', '.join(f'{v:.4f}' for v in r.end_state[:3])})"

        return (f"{c.family} seed {c.map_seed} difficulty {c.difficulty:.2f}, apex "
                f"({', '.join(f'{v:.4f}' for v in c.apex)}), leg ({c.leg_angles[0]:.4f}, {c.leg_angles[1]:.4f}): "
                f"fast {outcome(self.fast)} | drake {outcome(self.drake)}")


def draw_cases3d(n_cases: int, seed: int, families=("course",), params: SlipParams | None = None) -> list[Case3D]:
    """Random hops over random maps of the given families, drawn so that many land: difficulty uniform in [0, 1],
    apex x in 0.5-12 m and y in +-1 m (where the features are), speed 0.3-3 m/s within 45 degrees of +x, the leg
    tilted up to atan(mu) from vertical within 60 degrees of the heading, and the foot 0.1-0.5 m above the highest
    ground within a leg length of the body; lengths and speeds in the hopper's units (``drakeslip.units``)."""
    params = params or SlipParams()
    units = units_of(params)
    families = check_height_map_families(families)
    rng = np.random.default_rng(seed)
    reach = params.leg_length
    cases = []
    for i in range(n_cases):
        name = families[i % len(families)]
        map_seed, difficulty = int(rng.integers(1_000_000)), float(rng.uniform(0.0, 1.0))
        height_map = height_map_family(name)(map_seed, difficulty, units.length)
        x, y = units.length * rng.uniform(0.5, 12.0), units.length * rng.uniform(-1.0, 1.0)
        speed, heading = units.speed * rng.uniform(0.3, 3.0), rng.uniform(-math.pi / 4, math.pi / 4)
        tilt, azimuth = rng.uniform(0.0, params.max_leg_angle), heading + rng.uniform(-math.pi / 3, math.pi / 3)
        u = (math.sin(tilt) * math.cos(azimuth), math.sin(tilt) * math.sin(azimuth), -math.cos(tilt))
        leg = (math.atan2(u[0], -u[2]), math.asin(u[1]))
        around = np.linspace(-reach, reach, 21)
        ground = float(np.nanmax(height_map.solid[height_map.index(*np.meshgrid(x + around, y + around))]))
        z = ground + reach * math.cos(tilt) + rng.uniform(0.1, 0.5)
        apex = (x, y, z, speed * math.cos(heading), speed * math.sin(heading))
        cases.append(Case3D(name, map_seed, difficulty, units.length, apex, leg))
    return cases


def compare_backends3d(n_cases: int, seed: int, families=("course",), params: SlipParams | None = None,
                       tolerance: float = 1e-6) -> AgreementReport:
    """Run every random case on both spatial backends and compare outcome, foothold and next apex."""
    params = params or SlipParams()
    step3d((0.0, 0.0, 1.0, 1.0, 0.0), (0.0, 0.0), HeightMap.flat(), params)   # compile outside the timing

    def hop(case, height_map, backend):
        return step3d(case.apex, case.leg_angles, height_map, params, backend=backend)

    return compare(draw_cases3d(n_cases, seed, tuple(families), params), Case3D.height_map, hop, Comparison3D,
                   tolerance)
