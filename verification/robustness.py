"""How likely is a plan to work on a noisy robot? Monte Carlo over a noise profile (``drakeslip.noise``).

Each draw executes the plan's footholds through the step-length controller, as the receding-horizon loop would
without replanning, on a robot drawn from the profile: the plan was made from an apex estimate, so the true start
is off by the state-estimation error; at every apex the controller is told the apex with a new error and aims on
a terrain map with the perception errors (filtered over ``map_filter`` cells, as the closed loop's robot filters
it); the leg reaches the commanded angle with the actuation error; and the hops run on a hopper with this draw's
stiffness, mass and friction. A draw succeeds when it completes the plan's first ``hops`` hops (all of them by
default) with no failure. The same seed gives the same draws and outcomes;
``confirm_on_drake`` reruns the first draws, with the same errors, on the Drake simulator.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from drakeslip import FailureMode, StepLengthController
from drakeslip.noise import NoiseProfile
from drakeslip.rollout import ROLLOUT_BACKENDS, rollout
from drakeslip.terrain import check_window

from planners.formats.plan import PlanRecord
from verification.report import wilson_interval


# The most draws a Monte Carlo takes: the 95 % interval of a million is +-0.1 % wide, more say nothing more (and a
# million fast-backend draws of a ten-hop plan take about an hour)
MAX_SAMPLES = 1_000_000


@dataclass
class Draw:
    """One robot of the Monte Carlo: its start, its hopper, what it senses of the ground (on a profile the map it aims
    on; on a height map the heights it aims the plan's footholds at) and its errors at each hop."""

    start: np.ndarray
    params: object
    sensed: object
    apex_errors: np.ndarray
    angle_errors: np.ndarray


@dataclass
class Robustness:
    """The draws and their outcomes: ``failures`` FailureMode codes (0 = success) and ``failed_hops`` (-1 =
    success) over the plan's first ``hops`` hops."""

    record: PlanRecord
    noise: NoiseProfile
    seed: int
    backend: str
    hops: int
    draws: list
    failures: np.ndarray
    failed_hops: np.ndarray
    map_filter: int = 1

    @property
    def n(self) -> int:
        return self.failures.size

    @property
    def successes(self) -> int:
        return int(np.sum(self.failures == 0))

    @property
    def rate(self) -> float:
        return self.successes / self.n

    @property
    def interval(self) -> tuple[float, float]:
        return wilson_interval(self.successes, self.n)

    def failure_counts(self) -> dict:
        codes, counts = np.unique(self.failures[self.failures != 0], return_counts=True)
        return {FailureMode(int(c)).name: int(k) for c, k in zip(codes, counts)}

    def to_dict(self) -> dict:
        """JSON-ready: the setting, the rate with its 95 % interval, the failure counts and, per draw, its apex
        errors (hops x (x, z, xdot)), leg-angle errors (hops), outcome ("ok" or the FailureMode) and failed hop."""
        return {"planner": self.record.planner, "noise": self.noise.to_dict(), "map_filter": self.map_filter,
                "seed": self.seed, "backend": self.backend, "hops": self.hops, "n": self.n, "successes": self.successes,
                "success_rate": self.rate, "success_interval": list(self.interval),
                "failures": self.failure_counts(),
                "draws": {"apex_errors": [d.apex_errors.tolist() for d in self.draws],
                          "angle_errors": [d.angle_errors.tolist() for d in self.draws],
                          "outcome": [FailureMode(int(c)).name if c else "ok" for c in self.failures],
                          "failed_hop": self.failed_hops.tolist()}}

    def format(self) -> str:
        lo, hi = self.interval
        n = self.noise
        lines = [f"{self.n} draws on the {self.backend} backend (seed {self.seed}), the plan's first {self.hops} of "
                 f"{len(self.record.footholds)} hops: apex error sd x {n.apex[0]:g} m, z {n.apex[1]:g} m, xdot "
                 f"{n.apex[2]:g} m/s; leg angle sd {n.leg_angle:g} rad; stiffness, mass +-{n.stiffness:g}, "
                 f"+-{n.mass:g}; friction +-{n.friction:g}; terrain heights sd {n.heights:g} m, edges sd {n.edges:g} m",
                 f"success rate {self.rate:.4f} ({self.successes}/{self.n}), 95% Wilson interval "
                 f"[{lo:.4f}, {hi:.4f}]"]
        counts = self.failure_counts()
        if counts:
            hops = np.bincount(self.failed_hops[self.failed_hops >= 0])
            lines.append("failures: " + ", ".join(f"{k} {v}" for k, v in counts.items())
                         + "; by hop: " + ", ".join(f"{h}: {c}" for h, c in enumerate(hops) if c))
        return "\n".join(lines)


@dataclass
class DrakeConfirmation:
    """The first ``n`` draws of a fast-backend ``Robustness`` rerun on Drake."""

    fast: np.ndarray        # FailureMode codes of those draws on the fast backend (0 = success)
    drake: np.ndarray       # ... and on Drake
    disagreements: list = field(default_factory=list)   # (draw index, fast outcome, drake outcome)

    @property
    def n(self) -> int:
        return self.fast.size

    @property
    def agreement(self) -> float:
        """Fraction of draws with the same outcome (success, or the same failure mode) on both backends."""
        return float(np.mean(self.fast == self.drake))

    def format(self) -> str:
        lines = [f"Drake rerun of the first {self.n} draws: success fast {np.sum(self.fast == 0)}/{self.n}, "
                 f"drake {np.sum(self.drake == 0)}/{self.n}; same outcome in {np.sum(self.fast == self.drake)}/"
                 f"{self.n} ({self.agreement:.1%})"]
        lines += [f"  draw {i}: fast {f}, drake {d}" for i, f, d in self.disagreements]
        return "\n".join(lines)


def draw_robots(record: PlanRecord, n: int, noise: NoiseProfile, seed: int, hops: int, map_filter: int = 1) -> list:
    """``n`` robots drawn from ``noise`` (in the plan's hopper's units, ``NoiseProfile.for_hopper``) for the plan's
    first ``hops`` hops (seeded); each filters the terrain map it senses over ``map_filter`` cells
    (``Terrain.denoised``, as the closed loop's robot does; 1: as sensed)."""
    rng = np.random.default_rng(seed)
    noise = noise.for_hopper(record.params)
    out = []
    for _ in range(n):
        errors = noise.apex_errors(rng, hops)
        start = np.asarray(record.apex) - errors[0]  # the plan's start was the estimate of the first apex
        params = noise.executed_params(record.params, rng)
        sensed = noise.perceived(record.terrain, rng, map_filter) if (noise.heights or noise.edges) else record.terrain
        out.append(Draw(start, params, sensed, errors, noise.angle_errors(rng, hops)))
    return out


def success_probability(record: PlanRecord, n: int, noise: NoiseProfile, seed: int = 0, backend: str = "fast",
                        hops: int | None = None, controller: StepLengthController | None = None,
                        map_filter: int = 1) -> Robustness:
    """Success rate of ``record``'s footholds over ``n`` robots drawn from ``noise`` (see the module doc), over
    its first ``hops`` hops (default all), each robot filtering its sensed map over ``map_filter`` cells."""
    hops, map_filter = checked_settings(record, n, noise, backend, ROLLOUT_BACKENDS, hops, map_filter)
    controller = (controller or StepLengthController.load_default()).for_params(record.params)
    draws = draw_robots(record, n, noise, seed, hops, map_filter)
    failures, failed = _run(record, draws, hops, controller, backend)
    return Robustness(record, noise, seed, backend, hops, draws, failures, failed, map_filter)


# many parameters: every setting of a Monte Carlo that the caller gives
def checked_settings(record, n: int, noise: NoiseProfile, backend: str, backends: tuple, hops: int | None,
                     map_filter: int) -> tuple:
    """(the hops counted, the map filter) of a Monte Carlo over ``record``'s plan: ``n`` an integer from 1 to
    MAX_SAMPLES, ``noise`` a NoiseProfile, ``backend`` one of ``backends``, ``hops`` (None: all) within the plan's,
    ``map_filter`` odd; ValueError or TypeError naming the bad one otherwise."""
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= MAX_SAMPLES:
        raise ValueError(f"n must be an integer from 1 to {MAX_SAMPLES}, got {n!r}")
    if not isinstance(noise, NoiseProfile):
        raise TypeError(f"noise must be a drakeslip.noise.NoiseProfile, got {type(noise).__name__}")
    if backend not in backends:
        raise ValueError(f"backend must be one of {backends}, got {backend!r}")
    total = len(record.footholds)
    hops = total if hops is None else hops
    if isinstance(hops, bool) or not isinstance(hops, int) or not 1 <= hops <= total:
        raise ValueError(f"hops must be an integer in [1, {total}], got {hops!r}")
    return hops, check_window(map_filter, "map_filter")


def confirm_on_drake(result: Robustness, n_small: int,
                     controller: StepLengthController | None = None) -> DrakeConfirmation:
    """Rerun the first ``n_small`` draws of a fast-backend ``result`` on Drake (about 0.1-0.2 s per hop)."""
    if result.backend != "fast":
        raise ValueError(f"confirm_on_drake compares a fast-backend result with Drake, got backend {result.backend!r}")
    if isinstance(n_small, bool) or not isinstance(n_small, int) or not 1 <= n_small <= result.n:
        raise ValueError(f"n_small must be an integer in [1, {result.n}], got {n_small!r}")
    controller = controller or StepLengthController.load_default()
    drake, _ = _run(result.record, result.draws[:n_small], result.hops, controller, "drake")
    fast = result.failures[:n_small]
    name = lambda code: FailureMode(int(code)).name if code else "ok"
    return DrakeConfirmation(fast, drake, [(i, name(fast[i]), name(drake[i]))
                                           for i in np.flatnonzero(fast != drake)])


def _run(record: PlanRecord, draws: list, hops: int, controller, backend: str):
    """Every draw's FailureMode code (0 = success) and the hop it failed in (-1 = success)."""
    footholds = [float(x) for x in record.footholds[:hops]]
    failures, failed = np.zeros(len(draws), dtype=np.int64), np.full(len(draws), -1)
    for i, d in enumerate(draws):
        if d.start[1] <= record.terrain.height_at(d.start[0]):
            failures[i], failed[i] = int(FailureMode.TRIP), 0  # a start below the ground: its foot is too
            continue
        run = rollout(d.start, record.terrain, d.params, footholds=footholds, controller=controller,
                      backend=backend, apex_errors=d.apex_errors, angle_errors=d.angle_errors, model=record.params,
                      sensed_terrain=d.sensed)
        failures[i], failed[i] = int(run.failure or 0), run.failed_hop
    return failures, failed
