"""How likely is a plan on a height map to work on a noisy hopper? ``verification.robustness`` for map plans
(``planners.formats.map_plan``), with the noise profile in its three-dimensional form (``drakeslip.spatial.noise``).

Each draw flies the plan's footholds, without replanning, on a hopper drawn from the profile: the true start is off
the plan's by the state-estimation error (the plan was made from an estimate), the hops run on a hopper with this
draw's stiffness, mass and friction, and the hopper aims each hop at the plan's foothold (x, y) at the height its
sensed map has there (the perception errors, filtered over ``map_filter`` cells as the map loop's robot filters
them). On the spatial SLIP (the fast step map, or Drake) the controller is also told each apex with a new error
and the leg reaches each angle (pitch, roll) with its own error. On the spatial robot
(``drakeslip.spatial.multibody``, built for the draw's hopper) the robot's own estimation and actuation take those
errors' place: it measures its state and aims with its own hip. A draw succeeds when it completes the plan's first
``hops`` hops with no failure. The same seed gives the same draws and outcomes.
"""
from __future__ import annotations

import math

import numpy as np

from drakeslip import FailureMode
from drakeslip.noise import NoiseProfile
from drakeslip.spatial.controller import leg_angles_for
from drakeslip.spatial.noise import angle_errors3d, apex_errors3d, perceived_map
from drakeslip.spatial.simulation import simulate3d
from drakeslip.spatial.stepmap import step3d

from planners.formats.map_plan import MapPlanRecord
from verification.robustness import DrakeConfirmation, Draw, Robustness, checked_settings

MAP_BACKENDS = ("fast", "drake", "multibody")


def draw_map_robots(record: MapPlanRecord, n: int, noise: NoiseProfile, seed: int, hops: int,
                    map_filter: int = 1) -> list:
    """``n`` hoppers drawn from ``noise`` (in the plan's hopper's units) for the plan's first ``hops`` hops, in the
    planar draws' order: the apex errors, the executed hopper, the sensed map, the angle errors. A draw keeps of its
    sensed map the heights the hopper aims at (``aimed_heights``), not the map: a thousand sensed copies of a suite's
    map would hold a gigabyte."""
    rng = np.random.default_rng(seed)
    noise = noise.for_hopper(record.params)
    out = []
    for _ in range(n):
        errors = apex_errors3d(noise, rng, hops)
        start = np.asarray(record.apex) - errors[0]   # the plan's start was the estimate of the first apex
        params = noise.executed_params(record.params, rng)
        sensed = perceived_map(noise, record.height_map, rng, map_filter) if (noise.heights or noise.edges) \
            else record.height_map
        out.append(Draw(start, params, aimed_heights(record, sensed, hops), errors, angle_errors3d(noise, rng, hops)))
    return out


def aimed_heights(record: MapPlanRecord, sensed, hops: int) -> np.ndarray:
    """The height the hopper aims each of the plan's first ``hops`` footholds at: its ``sensed`` map's there, or the
    plan's where the sensed map has a hole."""
    return np.array([sensed_height(sensed, x, y, z) for x, y, z in record.footholds[:hops]])


# many parameters: the plan, the Monte Carlo's size, profile and seed, and how each draw runs, each with a default
def map_success_probability(record: MapPlanRecord, n: int, noise: NoiseProfile, seed: int = 0, backend: str = "fast",
                            hops: int | None = None, map_filter: int = 1) -> Robustness:
    """Success rate of ``record``'s footholds over ``n`` hoppers drawn from ``noise`` (module doc) on ``backend``
    (fast, drake or multibody), over its first ``hops`` hops (default all)."""
    hops, map_filter = checked_settings(record, n, noise, backend, MAP_BACKENDS, hops, map_filter)
    draws = draw_map_robots(record, n, noise, seed, hops, map_filter)
    failures, failed = run_draws(record, draws, hops, backend)
    return Robustness(record, noise, seed, backend, hops, draws, failures, failed, map_filter)


def confirm_map_on_drake(result: Robustness, n_small: int) -> DrakeConfirmation:
    """Rerun the first ``n_small`` draws of a fast-backend ``result`` on Drake, with the same errors."""
    if result.backend != "fast":
        raise ValueError(f"confirm_map_on_drake compares a fast-backend result with Drake, got {result.backend!r}")
    if isinstance(n_small, bool) or not isinstance(n_small, int) or not 1 <= n_small <= result.n:
        raise ValueError(f"n_small must be an integer in [1, {result.n}], got {n_small!r}")
    drake, _ = run_draws(result.record, result.draws[:n_small], result.hops, "drake")
    fast = result.failures[:n_small]
    name = lambda code: FailureMode(int(code)).name if code else "ok"   # noqa: E731 - a code's name, here only
    return DrakeConfirmation(fast, drake, [(i, name(fast[i]), name(drake[i])) for i in np.flatnonzero(fast != drake)])


def run_draws(record: MapPlanRecord, draws: list, hops: int, backend: str):
    """Every draw's FailureMode code (0 = success) and the hop it failed in (-1 = success)."""
    failures, failed = np.zeros(len(draws), dtype=np.int64), np.full(len(draws), -1)
    for i, d in enumerate(draws):
        targets = [(x, y, z) for (x, y, _), z in zip(record.footholds[:hops], d.sensed)]
        if d.start[2] <= record.height_map.height_at(d.start[0], d.start[1]):
            code, hop = int(FailureMode.TRIP), 0   # a start below the ground: its foot is too
        elif backend == "multibody":
            code, hop = on_robot(record, d, targets)
        else:
            code, hop = on_slip(record, d, targets, backend)
        failures[i], failed[i] = code, hop
    return failures, failed


def sensed_height(sensed, x: float, y: float, planned: float) -> float:
    """The height the hopper's sensed map has under (x, y); the plan's where the sensed map has a hole there."""
    z = sensed.height_at(x, y)
    return planned if np.isnan(z) else float(z)


def told_angles(record: MapPlanRecord, d: Draw, apex, k: int, target):
    """The leg angles reached at hop ``k``: aimed from the apex told (``apex`` plus the draw's error) at ``target``
    for the plan's hopper, plus the draw's angle errors; None where the target is out of the leg's reach or the
    error takes an angle past horizontal."""
    try:
        angles = leg_angles_for(tuple(np.add(apex, d.apex_errors[k])), target, record.params)
    except ValueError:
        return None
    reached = tuple(float(a + e) for a, e in zip(angles, d.angle_errors[k]))
    return reached if max(map(abs, reached)) < math.pi / 2 else None


def on_slip(record: MapPlanRecord, d: Draw, targets: list, backend: str) -> tuple:
    """(FailureMode code, failed hop) of draw ``d`` (a start above the ground) on the spatial SLIP's fast step map or
    Drake; a hop the leg cannot aim is a TRIP."""
    if backend == "drake":
        aimed = []

        def command(apex, k):
            if k >= len(targets):
                return None
            angles = told_angles(record, d, apex, k, targets[k])
            aimed.append(angles)
            return angles
        sim = simulate3d(tuple(d.start), command, record.height_map, d.params, max_hops=len(targets) + 1)
        if sim.failure is not None:
            return int(sim.failure), len(sim.apexes)
        return (int(FailureMode.TRIP), len(aimed) - 1) if None in aimed else (0, -1)
    apex = tuple(float(v) for v in d.start)
    for k, target in enumerate(targets):
        angles = told_angles(record, d, apex, k, target)
        if angles is None:
            return int(FailureMode.TRIP), k
        hop = step3d(apex, angles, record.height_map, d.params)
        if not hop.ok:
            return int(hop.failure), k
        apex = tuple(hop.next_apex)
    return 0, -1


def on_robot(record: MapPlanRecord, d: Draw, targets: list) -> tuple:
    """(FailureMode code, failed hop) of draw ``d`` (a start above the ground) on the spatial robot built for its
    hopper."""
    from drakeslip.spatial.multibody.gait import execute
    from drakeslip.spatial.multibody.robot import SpatialRobotParams

    log = execute(tuple(d.start), record.height_map, targets, SpatialRobotParams.for_hopper(d.params))
    return (0, -1) if log.failure is None else (int(log.failure.mode), len(log.apexes))
