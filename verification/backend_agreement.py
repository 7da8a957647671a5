"""Do the fast and the Drake step maps agree? Random hops on generated terrain, compared case by case."""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

import drakeslip as ds
from drakeslip.terrain import check_families, family


@dataclass(frozen=True)
class Case:
    """One random hop: terrain family and seed, apex, leg angle."""

    family: str
    terrain_seed: int
    apex: ds.ApexState
    leg_angle: float

    def terrain(self) -> ds.Terrain:
        return family(self.family)(self.terrain_seed)


@dataclass(frozen=True)
class Comparison:
    case: Case
    fast: ds.StepResult
    drake: ds.StepResult

    @property
    def same_outcome(self) -> bool:
        return self.fast.failure == self.drake.failure

    @property
    def both_ok(self) -> bool:
        return self.fast.ok and self.drake.ok

    @property
    def touchdown_deviation(self) -> float:
        """|fast - drake| foothold [m] (both ok only, else NaN)."""
        return abs(self.fast.touchdown_x - self.drake.touchdown_x) if self.both_ok else math.nan

    @property
    def apex_deviation(self) -> float:
        """Largest of |dx|, |dz| between the next apexes [m] (both ok only, else NaN)."""
        if not self.both_ok:
            return math.nan
        return max(abs(self.fast.next_apex.x - self.drake.next_apex.x),
                   abs(self.fast.next_apex.z - self.drake.next_apex.z))

    @property
    def speed_deviation(self) -> float:
        """|fast - drake| next apex forward speed [m/s] (both ok only, else NaN)."""
        return abs(self.fast.next_apex.xdot - self.drake.next_apex.xdot) if self.both_ok else math.nan

    def describe(self) -> str:
        c = self.case
        apex = ", ".join(f"{v:.4f}" for v in c.apex)

        def outcome(r):
            name = "ok" if r.ok else r.failure.name
            return f"{name} at t={r.time:.4f} x={r.end_state[0]:.4f} z={r.end_state[1]:.4f}"

        return (f"{c.family} seed {c.terrain_seed}, apex ({apex}), angle {c.leg_angle:.4f}: "
                f"fast {outcome(self.fast)} | drake {outcome(self.drake)}")


@dataclass
class AgreementReport:
    comparisons: list[Comparison]
    tolerance: float
    fast_seconds: float
    drake_seconds: float
    outcomes: dict = field(default_factory=dict)

    @property
    def n_cases(self) -> int:
        return len(self.comparisons)

    @property
    def disagreements(self) -> list[Comparison]:
        """Cases where the backends report different outcomes (ok / which failure)."""
        return [c for c in self.comparisons if not c.same_outcome]

    @property
    def disagreement_rate(self) -> float:
        return len(self.disagreements) / max(self.n_cases, 1)

    @property
    def both_ok(self) -> list[Comparison]:
        return [c for c in self.comparisons if c.both_ok]

    def worst(self, attribute: str) -> Comparison | None:
        return max(self.both_ok, key=lambda c: getattr(c, attribute), default=None)

    @property
    def worst_touchdown_deviation(self) -> float:
        worst = self.worst("touchdown_deviation")
        return worst.touchdown_deviation if worst else 0.0

    @property
    def worst_apex_deviation(self) -> float:
        worst = self.worst("apex_deviation")
        return worst.apex_deviation if worst else 0.0

    @property
    def beyond_tolerance(self) -> list[Comparison]:
        """Cases where both succeed but foothold or next apex differ by more than ``tolerance``."""
        return [c for c in self.both_ok if max(c.touchdown_deviation, c.apex_deviation) > self.tolerance]

    def format(self) -> str:
        lines = [f"{self.n_cases} cases, {len(self.both_ok)} succeed on both backends; outcomes (fast): "
                 + ", ".join(f"{k} {v}" for k, v in sorted(self.outcomes.items())),
                 f"outcome disagreement: {len(self.disagreements)}/{self.n_cases} = {self.disagreement_rate:.1%}"]
        for attribute, unit in (("touchdown_deviation", "m"), ("apex_deviation", "m"), ("speed_deviation", "m/s")):
            worst = self.worst(attribute)
            if worst is not None:
                lines.append(f"worst {attribute.replace('_', ' ')}: {getattr(worst, attribute):.3e} {unit}")
        lines.append(f"beyond {self.tolerance * 1e3:g} mm: {len(self.beyond_tolerance)}")
        for c in self.disagreements + self.beyond_tolerance:
            lines.append("  " + c.describe())
        n = max(self.n_cases, 1)
        lines.append(f"mean time per single step: fast {self.fast_seconds / n * 1e6:.1f} us, "
                     f"drake {self.drake_seconds / n * 1e3:.1f} ms")
        return "\n".join(lines)


def best_time(fn, repeats: int) -> float:
    """Seconds of the fastest of ``repeats`` calls of ``fn`` (the least disturbed by a busy machine)."""
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def draw_cases(n_cases: int, seed: int, families=("step",), params: ds.SlipParams | None = None) -> list[Case]:
    """Random hops on random terrains of the given families, drawn so that many succeed: apex x in 0.5-12 m
    (where the generated features are), the foot 0.1-0.5 m above the highest ground within a leg length of the
    body (an apex only 0.1-0.5 m above the ground would mostly TRIP with a 0.5 m leg), forward speed
    0.3-3 m/s, leg angle within +-atan(mu)."""
    params = params or ds.SlipParams()
    families = check_families(families)
    rng = np.random.default_rng(seed)
    reach = params.leg_length
    cases = []
    for i in range(n_cases):
        name = families[i % len(families)]
        terrain_seed = int(rng.integers(1_000_000))
        terrain = family(name)(terrain_seed)
        x = rng.uniform(0.5, 12.0)
        angle = rng.uniform(-params.max_leg_angle, params.max_leg_angle)
        ground = float(np.max(terrain.height_at(np.linspace(x - reach, x + reach, 21))))
        z = ground + reach * math.cos(angle) + rng.uniform(0.1, 0.5)
        cases.append(Case(name, terrain_seed, ds.ApexState(x, z, rng.uniform(0.3, 3.0)), angle))
    return cases


def compare_backends(n_cases: int, seed: int, families=("step",), params: ds.SlipParams | None = None,
                     tolerance: float = 2e-3) -> AgreementReport:
    """Run every random case on both backends and compare outcome, foothold and next apex."""
    params = params or ds.SlipParams()
    ds.step((0.0, 1.0, 1.0), 0.0, ds.Terrain.flat(), params)  # load the compiled kernel outside the timing

    def hop(case, terrain, backend):
        return ds.step(case.apex, case.leg_angle, terrain, params, backend=backend)

    return compare(draw_cases(n_cases, seed, tuple(families), params), Case.terrain, hop, Comparison, tolerance)


def compare(cases, ground_of, hop, comparison, tolerance: float) -> AgreementReport:
    """Every case flown by ``hop(case, ground, backend)`` on the fast and the Drake backends over its ground
    (``ground_of(case)``, made once, outside the timing), each backend timed, as ``comparison``s (``Comparison``, or
    the spatial hopper's) in one report; the outcomes counted on the fast backend."""
    comparisons, fast_seconds, drake_seconds, outcomes = [], 0.0, 0.0, {}
    for case in cases:
        ground = ground_of(case)
        t0 = time.perf_counter()
        fast = hop(case, ground, "fast")
        t1 = time.perf_counter()
        drake = hop(case, ground, "drake")
        t2 = time.perf_counter()
        fast_seconds += t1 - t0
        drake_seconds += t2 - t1
        name = "ok" if fast.ok else fast.failure.name
        outcomes[name] = outcomes.get(name, 0) + 1
        comparisons.append(comparison(case, fast, drake))
    return AgreementReport(comparisons, tolerance, fast_seconds, drake_seconds, outcomes)
