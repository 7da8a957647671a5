"""How likely is a plan to work when the start and the controller are not exact? Monte Carlo over noise.

Each draw executes the plan's footholds through the step-length controller (as the receding-horizon
evaluation does) from a perturbed start apex, adding Gaussian noise to every commanded leg angle: the model
of controller error (the trained controller itself lands within micrometres, so this error stands for the
real robot's actuation and sensing). A draw succeeds when it reaches the apex after the last foothold with
no failure. The fast backend runs all draws together, one ``step_batch`` call per hop; ``confirm_on_drake``
reruns the first draws, the same noise, on the Drake simulator and reports where the backends disagree.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from drakeslip import FailureMode, StepLengthController
from drakeslip.rollout import BACKENDS, rollouts

from planners.formats.plan import PlanRecord
from verification.report import wilson_interval


@dataclass
class Robustness:
    """The draws (``start`` (n, 3) apexes, ``angle_errors`` (n, hops) radians) and their outcomes:
    ``failures`` FailureMode codes (0 = success) and ``failed_hops`` (-1 = success)."""

    record: PlanRecord
    apex_noise: tuple
    angle_noise: float
    seed: int
    backend: str
    start: np.ndarray
    angle_errors: np.ndarray
    failures: np.ndarray
    failed_hops: np.ndarray

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

    def format(self) -> str:
        lo, hi = self.interval
        sx, sz, sv = self.apex_noise
        lines = [f"{self.n} draws on the {self.backend} backend (seed {self.seed}): start apex noise sd "
                 f"x {sx:g} m, z {sz:g} m, xdot {sv:g} m/s; leg-angle noise sd {self.angle_noise:g} rad",
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


def success_probability(record: PlanRecord, n: int, apex_noise=(0.0, 0.0, 0.0), angle_noise: float = 0.0,
                        seed: int = 0, backend: str = "fast",
                        controller: StepLengthController | None = None) -> Robustness:
    """Success rate of ``record``'s footholds over ``n`` draws: the start apex plus Gaussian noise with standard
    deviations ``apex_noise`` = (x [m], z [m], xdot [m/s]), every commanded leg angle plus Gaussian noise of
    standard deviation ``angle_noise`` [rad]. The same ``seed`` gives the same draws and outcomes."""
    if not (isinstance(n, int) and n >= 1):
        raise ValueError(f"n must be a positive integer, got {n!r}")
    apex_noise = tuple(float(s) for s in apex_noise)
    if len(apex_noise) != 3 or not all(math.isfinite(s) and s >= 0 for s in apex_noise + (float(angle_noise),)):
        raise ValueError(f"noise must be finite and non-negative: apex_noise (x, z, xdot) = {apex_noise}, "
                         f"angle_noise = {angle_noise!r}")
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    rng = np.random.default_rng(seed)
    start = np.asarray(record.apex) + rng.normal(size=(n, 3)) * apex_noise
    errors = rng.normal(size=(n, len(record.footholds))) * float(angle_noise)
    controller = controller or StepLengthController.load_default()
    controller.check_params(record.params)
    failures, hops = _run(record, start, errors, controller, backend)
    return Robustness(record, apex_noise, float(angle_noise), seed, backend, start, errors, failures, hops)


def confirm_on_drake(result: Robustness, n_small: int,
                     controller: StepLengthController | None = None) -> DrakeConfirmation:
    """Rerun the first ``n_small`` draws of a fast-backend ``result`` on Drake (about 0.1-0.2 s per hop)."""
    if result.backend != "fast":
        raise ValueError(f"confirm_on_drake compares a fast-backend result with Drake, got backend {result.backend!r}")
    if not (isinstance(n_small, int) and 1 <= n_small <= result.n):
        raise ValueError(f"n_small must be an integer in [1, {result.n}], got {n_small!r}")
    controller = controller or StepLengthController.load_default()
    drake, _ = _run(result.record, result.start[:n_small], result.angle_errors[:n_small], controller, "drake")
    fast = result.failures[:n_small]
    name = lambda code: FailureMode(int(code)).name if code else "ok"
    return DrakeConfirmation(fast, drake, [(i, name(fast[i]), name(drake[i]))
                                           for i in np.flatnonzero(fast != drake)])


def _run(record: PlanRecord, start, errors, controller, backend: str):
    """Every draw's FailureMode code (0 = success) and the hop it failed in (-1 = success)."""
    runs = rollouts(start, record.terrain, record.params, footholds=list(record.footholds), controller=controller,
                    backend=backend, angle_errors=errors)
    return (np.array([int(r.failure or 0) for r in runs], dtype=np.int64),
            np.array([r.failed_hop for r in runs], dtype=np.int64))
