"""Multi-hop trajectory optimization of the SLIP in Drake's ``MathematicalProgram``, warm-started by a seed.

A seed (``cold``, ``heuristic``, ``step``, ``lstm`` or ``lstm-guided``, see ``seed_footholds``) proposes N
footholds. They fix the discrete part of the problem, the flat run of cells ("segment") each hop lands on, and
the optimizer moves the footholds within their segments, together with everything continuous about the N hops.

Transcription (hop i = 0..N-1; apex 0 is the given start):

* decision variables: the leg angle theta_i, the fall time tf_i from apex i to touchdown, the foothold f_i, the
  stance duration T_i, the stance states S_i[k] = (x, z, xdot, zdot) on K+1 knots, and apex i+1 = (x, z, xdot);
* flight is analytic: touchdown S_i[0] = (x_a + v tf, z_a - g tf^2 / 2, v, -g tf) from apex a_i = (x_a, z_a, v);
  the foot of the leg held at theta_i (``dynamics.foot_position``) is then at (f_i, h_i), h_i the segment's
  height; apex i+1 is the top of the parabola from the liftoff state S_i[K];
* stance is direct collocation of ``dynamics.stance_derivatives`` with the foot pinned at (f_i, h_i):
  Chebyshev (pseudospectral: the degree-K polynomial through Chebyshev-Gauss-Lobatto knots has the model's
  derivative at every knot after the first) or Hermite-Simpson on K uniform segments. Liftoff is the leg back at
  rest length (``dynamics.leg_length``); at touchdown the leg must be compressing (``dynamics.leg_rate`` < 0);
* along stance, at the knots: the leg stays ``stroke_margin`` above ``min_leg_length`` (no bottom-out) and no
  longer than rest length before liftoff, inside ``friction_fraction`` of the friction cone, and the body moves
  forward; liftoff is upward;
* clearance (a Python constraint, since which cells lie under a point depends on where it is): the body on the
  stance knots and on the flight parabolas, sampled at ``flight_samples`` intervals per ascent and per descent,
  stays ``clearance`` above the highest cell under each interval (the terrain is piecewise constant, and a
  parabola's lowest point over an interval is an end); the extended foot, falling with the body from its apex
  position, stays ``clearance`` above every cell before its segment (checked where it enters the segment,
  where it is lowest over them) and above the cell under it at apex (no trip);
* footholds stay ``edge_margin`` inside their segment; apex speeds lie in [min_speed, max_speed]; the last apex
  lies ``target_margin`` past the plan's target (the hopper gets past it, with room for the open-loop drift).

Why Chebyshev with 20 knots by default: the solution is checked open loop, and the SLIP's apex return map at a
fixed leg angle is unstable (apex-height eigenvalue about 2-3 at these gaits), so a transcription error grows
about 3x per hop. Hermite-Simpson with 10 segments is off by ~1e-5 m per hop, which ruins a 12-hop open-loop
plan; Chebyshev with 20 knots agrees with Drake's simulator to ~5e-10 m per hop (``tests/test_trajopt.py``).

One definition of the SLIP: the collocation evaluates the numba-compiled ``drakeslip.dynamics`` functions'
own Python source on dual numbers (``generic_slip.py``), so the defects of a whole stance and their Jacobian
come from one vectorized pass; the simple algebraic constraints are symbolic expressions that Drake evaluates
in C++.

Cost (a documented trade; weights in ``CostWeights``):

    J =  edge     * sum_i sum_{finite edges e of segment i} (EDGE_SCALE / (f_i - e))^2     keep off edges
       + angle    * sum_i ((theta_{i+1} - theta_i) / ANGLE_SCALE)^2                       smooth leg commands
       + speed    * sum_i ((v_{i+1} - v_i) / SPEED_SCALE)^2   (v_0: the start's speed)    steady apex speed
       - progress * (x of the last apex - x of the start) / (target - x of the start)     go far

The edge term is (5 cm / distance)^2: large within a few cm of an edge, negligible a few decimetres away, so it
pushes footholds off edges without pulling them to segment centres. Angle and speed changes are measured in
units of 0.1 rad and 0.5 m/s; smooth commands and steady speeds are also what keeps an open-loop plan robust.
Progress is the only term that rewards distance, normalized so that reaching the target is worth 1.

Initial guess (``build_guess``): the seed's footholds executed by the controller on the fast step map, as the
seed's plan would be, which fixes every variable; where a hop fails or misses its foothold the guess re-anchors
the next apex on the footholds (energy-consistent), and if the solver does not converge from that guess it
tries once more with the plain chained one; a stop close to feasible is solved once more from its own point
(polish). The solver is SNOPT (IPOPT when SNOPT is unavailable, or asked for); major iterations are read from
the solver's print file. Every solution is checked by simulating its leg angles open loop on the Drake hybrid
simulator (``drakeslip.simulate``) on the true terrain (``verify``): no failure in its N hops and the last apex
past the target. With several starts (``TrajoptConfig.starts``) the cold and LSTM-guided seeds propose new
footholds (other strides, other samples) until a start is verified.
"""
from __future__ import annotations

import functools
import gc
import json
import math
import os
import re
import shutil
import tempfile
import time
from dataclasses import dataclass, field

import numpy as np

from drakeslip import ApexState, SlipParams, Terrain, step_batch
from drakeslip import dynamics as dyn
from drakeslip.fast_step import _rk4

from .base import FootstepSequence, Plan, Planner, Problem
from .evaluation import execute
from .generic_slip import Dual, dual_constraint, generic
from .presets import options_for
from .registry import planner_name, register

SEEDS = ("cold", "heuristic", "step", "lstm", "lstm-guided")
MULTI_START = ("cold", "lstm-guided")  # seeds with more than one start: other strides, other samples
COLD_STRIDES = (0, 1, -1, 2, -2)       # the cold seed's k-th start: this many hops more than the nominal gait
COLLOCATIONS = ("chebyshev", "hermite-simpson")
EDGE_SCALE = 0.05    # [m]   distance to an edge at which the edge cost of a foothold is 1
ANGLE_SCALE = 0.1    # [rad] change in leg angle between hops that costs 1
SPEED_SCALE = 0.5    # [m/s] change in apex speed between hops that costs 1
COLD_OVERSHOOT = 0.05  # [m] the cold seed's last foothold lands this far past the target
SEED_TOLERANCE = 0.02  # [m] a seed's hop counts as executed when it lands this close to its foothold


class TrajoptError(ValueError):
    """A seed or segment assignment that cannot be optimized (e.g. a foothold on a ditch)."""


@dataclass(frozen=True)
class CostWeights:
    edge: float = 1.0
    angle: float = 1.0
    speed: float = 1.0
    progress: float = 1.0


@dataclass(frozen=True)
class TrajoptConfig:
    """Transcription, constraint margins, cost and solver settings (see the module docstring)."""

    collocation: str = "chebyshev"   # or "hermite-simpson"
    knots: int = 20                  # stance knots minus one (Chebyshev degree, or Hermite-Simpson segments)
    max_hops: int = 24               # a seed's footholds beyond this many are dropped (slow starts take ~20
                                     # hops to cross the 7 m horizon; 24 hops solve in ~10-30 s)
    edge_margin: float = 0.03        # [m] footholds stay this far inside their segment
    friction_fraction: float = 0.95  # stance knots stay inside the cone of this fraction of mu
    stroke_margin: float = 0.003     # [m] knots stay this much above min_leg_length (covers the dip between
                                     # knots at mid-stance, ~1.5 mm for 20 Chebyshev knots)
    clearance: float = 0.01          # [m] body and extended foot above the terrain in flight (slow, low hops
                                     # of a Step-space seed lift the foot only 1-2 cm at apex)
    flight_samples: int = 6          # intervals per ascent and per descent checked for clearance
    target_margin: float = 0.05      # [m] the last apex is planned this far past the target
    min_speed: float = 0.3           # [m/s] apex speed bounds
    max_speed: float = 6.0
    min_stance_speed: float = 0.05   # [m/s] xdot at every stance knot (a STALL below 0)
    weights: CostWeights = field(default_factory=CostWeights)
    solver: str = "snopt"            # "snopt" or "ipopt"; snopt falls back to ipopt when unavailable
    lstm_weights: str | None = None  # checkpoint for the lstm seeds (default: the planners' committed one)
    solver_options: tuple = ()       # extra (name, value) pairs for the solver
    retry: bool = True               # no convergence from the re-anchored guess: try the chained one too
    starts: int = 1                  # starts per query for MULTI_START seeds, until one is verified
    polish_violation: float = 0.05   # an unconverged point this close to feasible (max violation) is solved
                                     # once more from itself (0 turns the restart off)
    major_iterations: int = 400
    optimality_tolerance: float = 1e-5
    feasibility_tolerance: float = 1e-7

    def node_times(self) -> np.ndarray:
        return node_times(self.collocation, self.knots)

    def __post_init__(self):
        if not (isinstance(self.knots, int) and self.knots >= 2):
            raise ValueError(f"knots must be an integer >= 2, got {self.knots!r}")
        if not (isinstance(self.starts, int) and 1 <= self.starts <= len(COLD_STRIDES)):
            raise ValueError(f"starts must be an integer in 1..{len(COLD_STRIDES)}, got {self.starts!r}")
        if not (isinstance(self.max_hops, int) and self.max_hops >= 1):
            raise ValueError(f"max_hops must be a positive integer, got {self.max_hops!r}")
        if not (isinstance(self.flight_samples, int) and self.flight_samples >= 1):
            raise ValueError(f"flight_samples must be a positive integer, got {self.flight_samples!r}")
        if self.collocation not in COLLOCATIONS:
            raise ValueError(f"collocation must be one of {COLLOCATIONS}, got {self.collocation!r}")
        if self.solver not in ("snopt", "ipopt"):
            raise ValueError(f"solver must be 'snopt' or 'ipopt', got {self.solver!r}")
        if not 0 < self.friction_fraction <= 1:
            raise ValueError(f"friction_fraction must lie in (0, 1], got {self.friction_fraction!r}")
        for name in ("edge_margin", "stroke_margin", "clearance", "target_margin", "polish_violation"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be non-negative, got {getattr(self, name)!r}")


def node_times(collocation: str, knots: int) -> np.ndarray:
    """Stance knot times as fractions of the stance duration: Chebyshev-Gauss-Lobatto points, or uniform."""
    if collocation == "chebyshev":
        return 0.5 * (1.0 - np.cos(np.pi * np.arange(knots + 1) / knots))
    return np.linspace(0.0, 1.0, knots + 1)


def differentiation_matrix(tau: np.ndarray) -> np.ndarray:
    """D with (D @ values)[i] = derivative at tau[i] of the polynomial through (tau, values) (barycentric)."""
    diff = tau[:, None] - tau[None, :]
    np.fill_diagonal(diff, 1.0)
    w = 1.0 / diff.prod(axis=1)
    D = (w[None, :] / w[:, None]) / diff
    np.fill_diagonal(D, 0.0)
    np.fill_diagonal(D, -D.sum(axis=1))
    return D


# ---- segments ----------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Segment:
    """A maximal run of cells at one height: x in [lo, hi) (lo = -inf / hi = +inf where the terrain extends
    flat beyond its ends)."""

    lo: float
    hi: float
    height: float
    ditch: bool

    def contains(self, x: float) -> bool:
        return self.lo <= x < self.hi

    def to_dict(self) -> dict:
        return {"lo": self.lo, "hi": self.hi, "height": self.height}


def segments(terrain: Terrain) -> list[Segment]:
    """The terrain's flat runs of cells, left to right."""
    h = terrain.heights
    breaks = np.flatnonzero(np.diff(h) != 0) + 1
    starts = np.concatenate([[0], breaks])
    ends = np.concatenate([breaks, [h.size]])
    out = []
    for k, (a, b) in enumerate(zip(starts, ends)):
        lo = -math.inf if k == 0 else terrain.x0 + a * terrain.cell
        hi = math.inf if k == len(starts) - 1 else terrain.x0 + b * terrain.cell
        out.append(Segment(float(lo), float(hi), float(h[a]), bool(h[a] <= terrain.ditch_height)))
    return out


def segment_of(terrain: Terrain, x: float) -> Segment:
    """The segment under x (the cell convention: a cell edge belongs to the cell on its right)."""
    for seg in segments(terrain):
        if seg.contains(x):
            return seg
    raise AssertionError("segments cover the real line")


def assign_segments(terrain: Terrain, footholds, margin: float, window_end: float = math.inf) -> list[Segment]:
    """The segment each foothold lands on, clipped to ``window_end``. Raises TrajoptError for a foothold on a
    ditch segment, or on a segment too short to hold a foothold ``margin`` away from both edges."""
    out = []
    for i, x in enumerate(np.asarray(footholds, dtype=np.float64)):
        if not math.isfinite(x):
            raise TrajoptError(f"foothold {i} is not finite: {x!r}")
        seg = segment_of(terrain, float(x))
        where = f"foothold {i} (x={x:.3f} m)"
        if seg.ditch:
            raise TrajoptError(f"{where} lies on a ditch segment [{seg.lo:.2f}, {seg.hi:.2f}) m at height "
                               f"{seg.height:g}: a foot cannot land in a ditch, so the seed cannot be optimized")
        seg = Segment(seg.lo, min(seg.hi, window_end), seg.height, False)
        if seg.hi - seg.lo <= 2 * margin:
            raise TrajoptError(f"{where} lies on a segment [{seg.lo:.2f}, {seg.hi:.2f}) m too short for a foothold "
                               f"{margin} m from both edges")
        out.append(seg)
    return out


def max_height(terrain: Terrain, a: float, b: float) -> float:
    """Highest terrain over x in [min(a, b), max(a, b)]."""
    i, j = terrain.index(min(a, b)), terrain.index(max(a, b))
    return float(terrain.heights[int(i):int(j) + 1].max())


def max_heights(terrain: Terrain, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``max_height`` for arrays of interval ends."""
    i, j = terrain.index(np.minimum(a, b)), terrain.index(np.maximum(a, b))
    h = terrain.heights
    return np.array([h[p:q + 1].max() for p, q in zip(i.tolist(), j.tolist())])


# ---- seeds -------------------------------------------------------------------------------------------------

def cold_footholds(problem: Problem, extra_hops: int = 0) -> np.ndarray:
    """A nominal uniform gait: the first foothold at the neutral point of the start apex on the ground under it,
    then equal steps (about the neutral gait's stride at the start speed) to COLD_OVERSHOOT past the target,
    on whatever segments those land. ``extra_hops`` more (or fewer, down to two footholds) equal steps cover the
    same distance."""
    from .heuristic import _interp, neutral_gait

    apex, terrain = problem.apex, problem.terrain
    offsets, advances = neutral_gait(problem.params.with_friction(1.0))
    drop = apex.z - terrain.height_at(apex.x)
    first = apex.x + _interp(offsets, apex.xdot, drop)
    stride = _interp(advances, apex.xdot, drop)
    last = max(problem.target_x + COLD_OVERSHOOT, first)
    nominal = 1 + max(0, math.ceil((last - first) / stride - 1e-9))
    n = max(nominal + extra_hops, min(nominal, 2))  # fewer hops, but still from the first foothold to the last
    return first + (last - first) * np.arange(n) / max(n - 1, 1)


def _seed_planner(label: str, options: dict | None, max_hops: int, lstm_weights, sample: int):
    """The seed's planner, built once per distinct arguments (so the one check_seed builds is the first start's)."""
    return _built_seed_planner(label, max_hops, str(lstm_weights) if lstm_weights else None, sample,
                               json.dumps(options or {}, sort_keys=True))


@functools.cache
def _built_seed_planner(label: str, max_hops: int, lstm_weights: str | None, sample: int, options_json: str):
    import planners

    name, options = planner_name(label), options_for(label, json.loads(options_json))
    if name.startswith("lstm") and lstm_weights and "weights" not in options:
        options["weights"] = lstm_weights
    if name == "lstm":  # the model's modes, fed back, for as many steps as the optimization takes
        options.setdefault("max_steps", max_hops)
    if name == "lstm-guided":  # footholds sampled from the model, each hop checked on the fast step map
        options["seed"] = sample
    if planners.takes(name, "controller"):
        options["controller"] = _controller()
    try:
        return planners.make(name, **options)
    except (TypeError, ValueError, OSError) as error:  # TypeError: an unknown option; OSError: missing weights
        raise ValueError(f"options for the {label} seed: {error}") from error


@functools.cache
def _controller():
    from drakeslip.controller import StepLengthController

    return StepLengthController.load_default()


def _check_seed_name(seed: str, options: dict | None) -> str:
    """The seed's name; a ValueError for an unknown one, or for options given to the cold gait."""
    name = planner_name(seed)
    if name not in SEEDS:
        raise ValueError(f"unknown seed {seed!r}; known seeds: {', '.join(SEEDS)} (each optionally NAME@VARIANT)")
    if name == "cold" and options:
        raise ValueError(f"the {seed} seed is a fixed gait and takes no options, got {options!r}")
    return name


def check_seed(seed: str, options: dict | None = None, config: TrajoptConfig | None = None) -> None:
    """A ValueError unless ``seed`` is a seed name, or ``NAME@VARIANT`` of one, and ``options`` (for the seed's
    planner) build it with ``config``'s max_hops and lstm_weights (the planner is kept for the first start);
    ``cold`` takes no options."""
    config = config or TrajoptConfig()
    if _check_seed_name(seed, options) != "cold":
        _seed_planner(seed, options, config.max_hops, config.lstm_weights, 0)


def seed_footholds(name: str, problem: Problem, max_hops: int = TrajoptConfig.max_hops,
                   lstm_weights: str | None = None, sample: int = 0,
                   options: dict | None = None) -> tuple[np.ndarray, int]:
    """Footholds from the named seed (planned on the problem's terrain), up to (and including) the first one
    past the target, and the step-map calls the seed's planner made (0 for ``cold``).
    ``name``: a seed, or ``NAME@VARIANT`` of one with ``options`` for its planner (e.g. ``lstm-guided@expert``
    with another model and lazy, apex-conditioned sampling), so two settings of a seed can be compared; a preset
    label (planners/presets.py) with no options runs with the preset's.
    ``lstm_weights``: a checkpoint for the ``lstm`` seeds (default: the committed model) unless ``options``
    name one. ``sample``: which start of a MULTI_START seed (the cold gait with COLD_STRIDES[sample] more hops,
    the LSTM-guided search with sampling seed ``sample``). An ``lstm`` plan short of the target (the one-step mode
    planner, e.g. with the learned re-ranker) is continued from the apexes the fast step map predicts."""
    kind = _check_seed_name(name, options)
    if sample and kind not in MULTI_START:
        raise ValueError(f"the {name} seed has one start; sample {sample!r} asked for another")
    ode_calls = 0
    if kind == "cold":
        footholds = cold_footholds(problem, COLD_STRIDES[sample])
    else:
        planner = _seed_planner(name, options, max_hops, lstm_weights, sample)
        plan = planner.plan(problem.apex, problem.terrain, problem.goal_x, problem.params)
        if not plan.success or plan.footholds.size == 0:
            raise TrajoptError(f"the {name} seed found no plan: {plan.message}")
        footholds, ode_calls = np.asarray(plan.footholds, dtype=np.float64), plan.ode_calls
        if kind == "lstm":
            footholds, ode_calls = _requeried(planner, problem, footholds, ode_calls, max_hops)
    passed = np.flatnonzero(footholds >= problem.target_x)
    return (footholds[:passed[0] + 1] if passed.size else footholds), ode_calls


def _requeried(planner, problem: Problem, footholds: np.ndarray, ode_calls: int, max_hops: int):
    """An LSTM plan that stops short of the target (the one-step mode planner's single foothold) continued: the
    controller aims each foothold, the fast step map predicts the apex after it, and the planner is asked again
    from there, until the footholds pass the target, number ``max_hops``, a hop fails or no plan is found. The
    footholds are still the model's; each prediction is one step-map call."""
    footholds = list(footholds)
    apex, done = problem.apex, 0
    while footholds[-1] < problem.target_x and len(footholds) < max_hops:
        hops = execute(apex, footholds[done:], _controller(), problem.terrain, problem.params, "fast")
        ode_calls += len(hops.apexes) + (hops.failure is not None)  # every hop tried, the failed one too
        if hops.failure is not None:
            return np.array(footholds), ode_calls
        apex, done = hops.apexes[-1], len(footholds)
        plan = planner.plan(apex, problem.terrain, problem.goal_x, problem.params)
        if not plan.success or plan.footholds.size == 0:
            break
        footholds += plan.footholds.tolist()
        ode_calls += plan.ode_calls
    return np.array(footholds), ode_calls


# ---- initial guess -----------------------------------------------------------------------------------------

@dataclass
class Guess:
    """Values for every decision variable of one N-hop problem (``build_guess`` makes one from footholds).
    ``fast_ok``: the fast step map executes the seed without failure (``fast_failure``: else the first one)."""

    leg_angles: np.ndarray     # (N,)
    fall_times: np.ndarray     # (N,)
    footholds: np.ndarray      # (N,)
    durations: np.ndarray      # (N,) stance
    stance: np.ndarray         # (N, K+1, 4)
    apexes: np.ndarray         # (N+1, 3), apexes[0] the start
    fast_ok: bool = False
    fast_failure: str = ""


def _stance_knots(s0, foot, params: SlipParams, tau: np.ndarray, max_time: float = 1.0):
    """Integrate stance from the touchdown state s0 (RK4 on the shared dynamics.stance_derivatives) until the
    leg is back at rest length; returns (duration, states at the times tau * duration), or None when it never
    lifts off."""
    p = params.as_array()
    fx, fz = foot
    L0 = params.leg_length
    h = 1e-4
    s, t = tuple(map(float, s0)), 0.0
    duration = None
    while t < max_time:
        prev, s = s, _rk4(s, fx, fz, h, p)
        t += h
        l_prev, l_new = dyn.leg_length(prev[0], prev[1], fx, fz), dyn.leg_length(s[0], s[1], fx, fz)
        if not l_new > 0.2 * params.min_leg_length:  # through the foot (or NaN): no stance to speak of
            return None
        if t > 5 * h and l_new >= L0 > l_prev:
            duration = t - h + h * (L0 - l_prev) / (l_new - l_prev)
            break
    if duration is None:
        return None

    def knots(T):
        s = tuple(map(float, s0))
        out = [s]
        for a, b in zip(tau[:-1], tau[1:]):
            for _ in range(20):
                s = _rk4(s, fx, fz, (b - a) * T / 20, p)
            out.append(s)
        return np.array(out)

    path = knots(duration)
    for _ in range(2):  # Newton on the liftoff time: the leg exactly at rest length at the last knot
        x, z, xd, zd = path[-1]
        rate = dyn.leg_rate(x, z, xd, zd, fx, fz)
        if rate <= 0:
            break
        duration -= (dyn.leg_length(x, z, fx, fz) - L0) / rate
        path = knots(duration)
    return duration, path


def _plausible(knots_out, foot, params: SlipParams) -> bool:
    """A stance guess worth starting from: it lifts off upward and forward, never stops or bottoms out."""
    if knots_out is None:
        return False
    duration, path = knots_out
    if not (np.all(np.isfinite(path)) and math.isfinite(duration)):
        return False
    legs = np.hypot(path[:, 0] - foot[0], path[:, 1] - foot[1])
    return bool(path[-1, 3] > 0.05 and np.all(path[:, 2] > 0.05) and legs.min() > params.min_leg_length
                and duration < 3 * math.pi / params.natural_frequency)


def _symmetric_stance(s0, foot, tau: np.ndarray, params: SlipParams):
    """A fallback stance guess: the touchdown state mirrored about the foot, a straight line between."""
    x, z, xd, zd = s0
    s1 = np.array([2 * foot[0] - x, z, xd, -zd])
    duration = math.pi / params.natural_frequency
    u = tau[:, None]
    return duration, (1 - u) * np.asarray(s0) + u * s1


def build_guess(apex, footholds, segs: list[Segment], terrain: Terrain, params: SlipParams,
                tau: np.ndarray, controller=None, reanchor: bool = True) -> Guess:
    """Execute the footholds as the seed's plan would be: at every apex the controller's leg angle for the next
    foothold, the hop on the fast step map (whose next apex the guess takes). Stance knots (at the times
    ``tau``, fractions of the stance) come from integrating the shared stance equations from the touchdown on
    the assigned segment; flight is closed form.

    A hop that fails on the fast step map, or lands more than SEED_TOLERANCE from its foothold, would leave
    the rest of the chain meaningless (a hop that nearly stalls sends the next one anywhere). The guess keeps
    that hop's stance (integrated, or a symmetric one where it stalls or bottoms out) and re-anchors the next
    apex: midway between the two footholds, as high above the higher of their segments as the start was above
    its ground, and as fast as the start's energy allows there (the SLIP conserves energy). With
    ``reanchor=False`` the chain goes on from that hop's liftoff instead."""
    controller = controller or _controller()
    L0, g = params.leg_length, params.gravity
    apex = ApexState(*map(float, apex))
    footholds = np.asarray(footholds, dtype=np.float64)
    n = footholds.size
    angles, falls, durs, feet = np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n)
    stance = np.zeros((n, tau.size, 4))
    apexes = np.zeros((n + 1, 3))
    apexes[0] = apex
    limit = 0.97 * math.atan(params.friction)
    energy = g * apex.z + 0.5 * apex.xdot ** 2                       # per unit mass
    above = max(apex.z - terrain.height_at(apex.x), L0 + 0.15)       # apex height above the ground
    fast_ok, fast_failure = True, ""
    for i in range(n):
        a = ApexState(*apexes[i])
        h = segs[i].height
        theta = float(np.clip(controller.leg_angle(a, footholds[i], terrain), -limit, limit))
        tf = math.sqrt(2 * max(a.z - L0 * math.cos(theta) - h, 1e-6) / g)
        s0 = np.array([a.x + a.xdot * tf, h + L0 * math.cos(theta), a.xdot, -g * tf])
        foot = (s0[0] + L0 * math.sin(theta), h)
        knots_out = _stance_knots(s0, foot, params, tau)
        hop = step_batch(apexes[i], [theta], terrain, params).result(0)
        lands = hop.ok and abs(hop.touchdown_x - footholds[i]) < SEED_TOLERANCE
        if lands and knots_out is not None:
            # a hop the fast step map executes: its stance is the integrated one, its apex the step map's
            angles[i], falls[i], durs[i], feet[i], stance[i] = theta, tf, knots_out[0], foot[0], knots_out[1]
            apexes[i + 1] = hop.next_apex
            continue
        if fast_ok:
            fast_ok = False
            fast_failure = (f"hop {i}: {hop.failure.name}" if not hop.ok else
                            f"hop {i}: lands at x={hop.touchdown_x:.3f}, not {footholds[i]:.3f}")
        if not _plausible(knots_out, foot, params):  # the hop fails in stance: guess a symmetric one instead
            knots_out = _symmetric_stance(s0, foot, tau, params)
        dur, path = knots_out
        angles[i], falls[i], durs[i], feet[i], stance[i] = theta, tf, dur, foot[0], path
        if not reanchor:  # go on from the liftoff
            lo = path[-1]
            zd, xd = max(lo[3], 0.05), max(lo[2], 0.05)
            apexes[i + 1] = (lo[0] + xd * zd / g, lo[1] + zd * zd / (2 * g), xd)
            continue
        # re-anchor the next apex on the seed's footholds
        nxt = footholds[i + 1] if i + 1 < n else footholds[i] + (footholds[i] - (footholds[i - 1] if i else a.x))
        top = max(h, segs[i + 1].height if i + 1 < n else h)
        z = top + above
        v = min(max(math.sqrt(max(2 * (energy - g * z), 0.0)), 0.5), 3.5)
        apexes[i + 1] = (0.5 * (footholds[i] + nxt), z, v)
    return Guess(angles, falls, feet, durs, stance, apexes, fast_ok, fast_failure)


# ---- the program -------------------------------------------------------------------------------------------

@dataclass
class TrajoptResult:
    converged: bool
    solver: str
    status: str
    iterations: int | None
    solve_time_s: float
    build_time_s: float
    cost: float
    leg_angles: np.ndarray
    footholds: np.ndarray
    apexes: np.ndarray
    durations: np.ndarray
    max_violation: float
    violations: dict
    x: np.ndarray | None = None   # the solver's last point, every decision variable

    def summary(self) -> dict:
        return {"converged": self.converged, "solver": self.solver, "status": self.status,
                "iterations": self.iterations, "solve_time_s": self.solve_time_s,
                "build_time_s": self.build_time_s, "cost": self.cost, "max_violation": self.max_violation,
                "violations": self.violations,
                "leg_angles": self.leg_angles.tolist(), "footholds": self.footholds.tolist(),
                "apexes": self.apexes.tolist()}


def _add_expressions(prog, exprs, lb, ub):
    """lb <= exprs <= ub for a vector of symbolic expressions, as one ExpressionConstraint (Drake evaluates it
    and its symbolic gradient in C++)."""
    from pydrake.solvers import ExpressionConstraint
    from pydrake.symbolic import Expression

    exprs = np.array([e if isinstance(e, Expression) else Expression(e) for e in np.ravel(np.array(exprs, object))])
    m = exprs.size
    c = ExpressionConstraint(exprs, np.broadcast_to(np.asarray(lb, float), (m,)).copy(),
                             np.broadcast_to(np.asarray(ub, float), (m,)).copy())
    return prog.AddConstraint(c, c.vars())


class SlipTrajopt:
    """The N-hop program for a start apex, the segments the N footholds must land on, and a target the last
    one must pass. ``prog`` is the MathematicalProgram; ``groups`` maps constraint names to their bindings."""

    def __init__(self, apex, terrain: Terrain, segs: list[Segment], params: SlipParams | None = None,
                 target_x: float = -math.inf, config: TrajoptConfig | None = None):
        from pydrake.solvers import MathematicalProgram

        t0 = time.perf_counter()
        self.apex0 = ApexState(*map(float, apex)).validate()
        self.terrain = terrain
        self.segs = list(segs)
        self.params = params = params or SlipParams()
        self.config = cfg = config or TrajoptConfig()
        self.target_x = float(target_x)
        if not self.segs:
            raise TrajoptError("no footholds to optimize")
        for i, s in enumerate(self.segs):
            if s.ditch:
                raise TrajoptError(f"foothold {i} is assigned to a ditch segment [{s.lo:.2f}, {s.hi:.2f})")
        N, K = len(self.segs), cfg.knots
        self.N, self.K = N, K
        p = params.as_array()
        L0, g, mu = params.leg_length, params.gravity, params.friction
        foot_pos = generic(dyn.foot_position)
        leg_len, leg_rate = generic(dyn.leg_length), generic(dyn.leg_rate)
        prog = self.prog = MathematicalProgram()
        self.theta = prog.NewContinuousVariables(N, "theta")
        self.tf = prog.NewContinuousVariables(N, "tf")
        self.foot = prog.NewContinuousVariables(N, "f")
        self.dur = prog.NewContinuousVariables(N, "T")
        self.S = [prog.NewContinuousVariables(K + 1, 4, f"s{i}") for i in range(N)]
        self.A = prog.NewContinuousVariables(N, 3, "apex")  # the apex after hop i
        self.groups: dict = {}

        def add(group, binding):
            self.groups.setdefault(group, []).append(binding)

        limit = 0.97 * math.atan(mu)
        half = math.pi / params.natural_frequency
        mu_c = cfg.friction_fraction * mu
        for i, seg in enumerate(self.segs):
            ax, az, av = self.apex_before(i)
            S, th, tf, f, T = self.S[i], self.theta[i], self.tf[i], self.foot[i], self.dur[i]
            h = seg.height
            prog.AddBoundingBoxConstraint(-limit, limit, th)
            prog.AddBoundingBoxConstraint(0.01, 2.0, tf)
            prog.AddBoundingBoxConstraint(0.3 * half, 3.0 * half, T)
            add("foothold_segment", prog.AddBoundingBoxConstraint(seg.lo + cfg.edge_margin,
                                                                  seg.hi - cfg.edge_margin, f))
            # touchdown: the body falls from apex i for tf; the foot of the leg held at theta reaches (f, h)
            td = [ax + av * tf, az - 0.5 * g * tf * tf, av, -g * tf]
            add("touchdown", _add_expressions(prog, [S[0, j] - td[j] for j in range(4)], 0, 0))
            fx, fz = foot_pos(S[0, 0], S[0, 1], th, p)
            add("foot_on_terrain", _add_expressions(prog, [fx - f, fz - h], 0, 0))
            add("leg_loads", _add_expressions(prog, leg_rate(S[0, 0], S[0, 1], S[0, 2], S[0, 3], f, h), -np.inf,
                                              -1e-3))
            # stance: collocation of the shared stance equations
            variables = np.concatenate([S.reshape(-1), [f, T]])
            binding = prog.AddConstraint(dual_constraint(self._collocation(h), 4 * K), np.zeros(4 * K),
                                         np.zeros(4 * K), variables)
            binding.evaluator().SetGradientSparsityPattern(self._collocation_sparsity())
            add("dynamics", binding)
            # along stance: no bottom-out, no longer than rest length before liftoff (interior knots) ...
            inner = np.concatenate([S[1:K, :2].reshape(-1), [f]])
            binding = prog.AddConstraint(dual_constraint(self._leg_lengths(h), K - 1),
                                         np.full(K - 1, params.min_leg_length + cfg.stroke_margin),
                                         np.full(K - 1, L0), inner)
            binding.evaluator().SetGradientSparsityPattern(
                [(k, c) for k in range(K - 1) for c in (2 * k, 2 * k + 1, 2 * (K - 1))])
            add("leg_length", binding)
            # ... inside the friction cone, mu' (z - h) >= |x - f| (linear: the foot height is known) ...
            rows = np.zeros((2 * (K + 1), 2 * (K + 1) + 1))
            for k in range(K + 1):
                for r, sign in ((2 * k, 1.0), (2 * k + 1, -1.0)):
                    rows[r, k], rows[r, K + 1 + k], rows[r, -1] = -sign, mu_c, sign
            add("friction", prog.AddLinearConstraint(rows, np.full(2 * (K + 1), mu_c * h), np.full(2 * (K + 1), np.inf),
                                                     np.concatenate([S[:, 0], S[:, 1], [f]])))
            # ... and moving forward (a STALL otherwise)
            prog.AddBoundingBoxConstraint(cfg.min_stance_speed, np.inf, S[:, 2])
            x, z, xd, zd = S[K]
            add("liftoff", _add_expressions(prog, leg_len(x, z, f, h), L0, L0))
            prog.AddBoundingBoxConstraint(0.05, np.inf, zd)  # leaves the ground upward: an apex follows
            # flight to the next apex, in closed form
            A = self.A[i]
            add("apex", _add_expressions(prog, [A[0] - (x + xd * zd / g), A[1] - (z + zd * zd / (2 * g)), A[2] - xd],
                                         0, 0))
            prog.AddBoundingBoxConstraint(cfg.min_speed, cfg.max_speed, A[2])
        if math.isfinite(self.target_x):  # the hopper passes the target: the last apex lies beyond it
            add("target", prog.AddBoundingBoxConstraint(self.target_x + cfg.target_margin, np.inf, self.A[N - 1, 0]))
        for k in range(N + 1):
            variables, fn, m = self._clearance(k)
            add("clearance", prog.AddConstraint(fn, np.full(m, cfg.clearance), np.full(m, np.inf), variables))
        self._add_costs()
        self.build_time_s = time.perf_counter() - t0

    def apex_before(self, i: int):
        """Apex i (the start for i = 0): constants or decision variables."""
        return tuple(self.apex0) if i == 0 else tuple(self.A[i - 1])

    def _collocation(self, h: float):
        """Collocation defects of one stance on a foot at height h, over (S (K+1, 4) row-major, f, T): 4 blocks
        (x, z, xdot, zdot) of K defects, from the shared ``dynamics.stance_derivatives``. Chebyshev: the
        degree-K polynomial through the knots has the model's derivative at knots 1..K (spectral accuracy: the
        stance is smooth); Hermite-Simpson: the compressed form on K uniform segments."""
        K, p = self.K, self.params.as_array()
        F = generic(dyn.stance_derivatives)
        rows = np.arange(K + 1) * 4
        D = differentiation_matrix(node_times(self.config.collocation, K))[1:]

        def chebyshev(v):
            comp = [v[rows + j] for j in range(4)]
            f, T = v[4 * (K + 1)], v[4 * (K + 1) + 1]
            d = F(*comp, f, h, p)
            return Dual.concat([D @ c - T * dc[1:] for c, dc in zip(comp, d)])

        def hermite_simpson(v):
            comp = [v[rows + j] for j in range(4)]
            f, T = v[4 * (K + 1)], v[4 * (K + 1) + 1]
            s0, s1 = [c[:-1] for c in comp], [c[1:] for c in comp]
            d0, d1 = F(*s0, f, h, p), F(*s1, f, h, p)
            dt = T / K
            sm = [0.5 * (a + b) + dt / 8.0 * (da - db) for a, b, da, db in zip(s0, s1, d0, d1)]
            dm = F(*sm, f, h, p)
            return Dual.concat([b - a - dt / 6.0 * (da + 4.0 * dc + db)
                                for a, b, da, dc, db in zip(s0, s1, d0, dm, d1)])

        return chebyshev if self.config.collocation == "chebyshev" else hermite_simpson

    def _leg_lengths(self, h: float):
        """Leg length (``dynamics.leg_length``) at the interior stance knots, over their (x, z) and the foot."""
        K, leg_len = self.K, generic(dyn.leg_length)

        def lengths(v):
            return leg_len(v[0:2 * (K - 1):2], v[1:2 * (K - 1):2], v[2 * (K - 1)], h)

        return lengths

    def _collocation_sparsity(self) -> list:
        """(row, column) of the collocation defects' structural nonzeros (see ``_collocation``): defect (j, k)
        involves state j on the knots it couples, every state at knot k, the foot and the duration."""
        K, cheb = self.K, self.config.collocation == "chebyshev"
        pattern = set()
        for j in range(4):
            for k in range(K):
                row = j * K + k
                knots = range(K + 1) if cheb else (k, k + 1)
                pattern.update((row, 4 * n + j) for n in knots)
                for n in ((k + 1,) if cheb else (k, k + 1)):
                    pattern.update((row, 4 * n + c) for c in range(4))
                pattern.update({(row, 4 * (K + 1)), (row, 4 * (K + 1) + 1)})
        return sorted(pattern)

    # -- clearance: a Python constraint, since the terrain under a sample depends on where the sample is --------
    def _clearance(self, k: int):
        """Body clearance over flight k (the ascent after stance k-1, the descent to stance k) and stance k, and
        the extended foot's clearance over the cells before segment k: (variables, function, outputs)."""
        params, terrain = self.params, self.terrain
        g = params.gravity
        N, K, M = self.N, self.K, self.config.flight_samples
        p = params.as_array()
        foot_pos = generic(dyn.foot_position)
        parts = []
        if k > 0:
            parts.append(self.S[k - 1][K])                 # liftoff state of the previous stance
        if 0 < k < N:
            parts.append(self.A[k - 1])                    # apex k
        if k < N:
            parts.append([self.theta[k], self.tf[k]])
            parts.append(self.S[k][:, :2].reshape(-1))     # body (x, z) on the stance knots
        variables = np.concatenate([np.ravel(v) for v in parts])
        seg = self.segs[k] if k < N else None
        n_points = (M + 1 if k > 0 else 0) + (M + 1 + K + 1 if k < N else 0)
        n_out = 2 * (n_points - 1) + (1 if k < N else 0)
        u = np.linspace(0.0, 1.0, M + 1)
        apex0 = tuple(self.apex0)

        def clearance(v):
            xs, zs, at = [], [], 0
            if k > 0:
                x, z, xd, zd = v[0], v[1], v[2], v[3]
                t = zd * (u / g)
                xs.append(x + xd * t)
                zs.append(z + zd * t - 0.5 * g * t * t)
                at = 4
            if k < N:
                if k > 0:
                    ax, az, av = v[at], v[at + 1], v[at + 2]
                    at += 3
                else:
                    ax, az, av = apex0
                theta, tf = v[at], v[at + 1]
                t = tf * u
                xs.append(ax + av * t)
                zs.append(az - 0.5 * g * t * t)
                body = v[at + 2:at + 2 + 2 * (K + 1)]
                xs.append(body[0::2])
                zs.append(body[1::2])
            X, Z = Dual.concat(xs), Dual.concat(zs)
            top = max_heights(terrain, X.val[:-1], X.val[1:])
            out = [Z[:-1] - top, Z[1:] - top]
            if k < N:
                # the extended foot falls with the body from its apex position; over the cells before its
                # segment it must stay above them, and it is lowest over them where it enters the segment
                fx, fz = foot_pos(ax, az, theta, p)
                reach = (seg.lo - fx) / av if math.isfinite(seg.lo) else None
                if reach is not None and reach.val > 0:
                    out.append(fz - 0.5 * g * reach * reach - max_height(terrain, float(fx.val), seg.lo - 1e-9))
                else:
                    out.append(fz - terrain.height_at(float(fx.val)))
            return Dual.concat(out)

        return variables, dual_constraint(clearance, n_out), n_out

    def _add_costs(self):
        w, N = self.config.weights, self.N
        if w.edge:
            for i, seg in enumerate(self.segs):
                for edge in (seg.lo, seg.hi):
                    if math.isfinite(edge):
                        self.prog.AddCost(w.edge * EDGE_SCALE ** 2 / ((self.foot[i] - edge) ** 2))
        # (sums built term by term: numpy arithmetic on arrays of symbolic variables trips spurious FP warnings)
        if w.angle and N > 1:
            self.prog.AddQuadraticCost(sum((w.angle / ANGLE_SCALE ** 2) * (self.theta[i + 1] - self.theta[i]) ** 2
                                           for i in range(N - 1)), is_convex=True)
        if w.speed:
            v = [self.apex0.xdot] + list(self.A[:, 2])
            self.prog.AddQuadraticCost(sum((w.speed / SPEED_SCALE ** 2) * (v[i + 1] - v[i]) ** 2 for i in range(N)),
                                       is_convex=True)
        if w.progress:
            span = max(self.target_x - self.apex0.x, 1.0) if math.isfinite(self.target_x) else 1.0
            self.prog.AddLinearCost(-w.progress * (self.A[N - 1, 0] - self.apex0.x) / span)

    # -- values ----------------------------------------------------------------------------------------------
    def guess_vector(self, guess: Guess) -> np.ndarray:
        """The decision-variable vector holding a Guess."""
        if guess.leg_angles.size != self.N or guess.stance.shape[1] != self.K + 1:
            raise ValueError(f"guess has {guess.leg_angles.size} hops and {guess.stance.shape[1]} knots; the "
                             f"program has {self.N} and {self.K + 1}")
        x = np.zeros(self.prog.num_vars())
        put = lambda var, val: x.__setitem__(self.prog.FindDecisionVariableIndices(np.ravel(var)), np.ravel(val))
        put(self.theta, guess.leg_angles)
        put(self.tf, guess.fall_times)
        put(self.foot, guess.footholds)
        put(self.dur, guess.durations)
        for i in range(self.N):
            put(self.S[i], guess.stance[i])
        put(self.A, guess.apexes[1:])
        return x

    def violations(self, x: np.ndarray) -> dict:
        """Largest violation of each constraint group at the decision vector x (0 = satisfied)."""
        out = {}
        for name, bindings in self.groups.items():
            worst = 0.0
            for b in bindings:
                val = np.atleast_1d(self.prog.EvalBinding(b, x))
                c = b.evaluator()
                worst = max(worst, float(np.max(np.maximum(c.lower_bound() - val, val - c.upper_bound()))))
            out[name] = max(worst, 0.0)
        return out

    def solve(self, guess: Guess | np.ndarray, print_file=None) -> TrajoptResult:
        """Solve from ``guess`` (or a decision-variable vector, such as a previous result's ``x``);
        ``print_file``: keep the solver's log there."""
        from pydrake.solvers import (CommonSolverOption, IpoptSolver, SnoptSolver, SolverOptions)

        cfg = self.config
        x0 = np.asarray(guess, dtype=np.float64) if isinstance(guess, np.ndarray) else self.guess_vector(guess)
        use_snopt = cfg.solver == "snopt" and SnoptSolver().available() and SnoptSolver().enabled()
        solver = SnoptSolver() if use_snopt else IpoptSolver()
        options = SolverOptions()
        fd, log = tempfile.mkstemp(prefix="trajopt-", suffix=".log")
        os.close(fd)
        try:
            if use_snopt:
                options.SetOption(CommonSolverOption.kPrintFileName, log)
                sid = solver.solver_id()
                options.SetOption(sid, "Major iterations limit", cfg.major_iterations)
                options.SetOption(sid, "Iterations limit", 100000)
                options.SetOption(sid, "Major optimality tolerance", cfg.optimality_tolerance)
                options.SetOption(sid, "Major feasibility tolerance", cfg.feasibility_tolerance)
            else:
                sid = solver.solver_id()
                options.SetOption(sid, "output_file", log)
                options.SetOption(sid, "file_print_level", 3)
                options.SetOption(sid, "print_level", 0)
                options.SetOption(sid, "max_iter", cfg.major_iterations)
                options.SetOption(sid, "tol", cfg.optimality_tolerance)
                options.SetOption(sid, "constr_viol_tol", cfg.feasibility_tolerance)
            for name, value in cfg.solver_options:
                options.SetOption(sid, name, value)
            collecting = gc.isenabled()
            gc.disable()  # the callbacks make many short-lived arrays; cyclic GC passes only cost time here
            t0 = time.perf_counter()
            try:
                result = solver.Solve(self.prog, x0, options)
            finally:
                solve_time = time.perf_counter() - t0
                if collecting:
                    gc.enable()
            with open(log, errors="replace") as f:
                text = f.read()
        finally:
            if print_file is not None:
                shutil.copy(log, print_file)
            os.unlink(log)
        pattern = r"No\. of major iterations\s+(\d+)" if use_snopt else r"Number of Iterations\.+:\s*(\d+)"
        found = re.findall(pattern, text)
        iterations = int(found[-1]) if found else None
        if use_snopt:
            status = f"SNOPT info {result.get_solver_details().info}"
        else:
            status = f"IPOPT status {result.get_solver_details().status}"
        x = result.GetSolution()
        viol = self.violations(x)
        val = lambda v: result.GetSolution(v)
        apexes = np.vstack([np.array(self.apex0)[None], val(self.A)])
        return TrajoptResult(converged=bool(result.is_success()), solver="snopt" if use_snopt else "ipopt",
                             status=status, iterations=iterations, solve_time_s=solve_time,
                             build_time_s=self.build_time_s, cost=float(result.get_optimal_cost()),
                             leg_angles=val(self.theta), footholds=val(self.foot), apexes=apexes,
                             durations=val(self.dur), max_violation=max(viol.values()), violations=viol, x=x)


# ---- verification and the whole pipeline ------------------------------------------------------------------

def verify(apex, leg_angles, terrain: Terrain, params: SlipParams, target_x: float) -> dict:
    """Simulate the leg angles open loop on the Drake hybrid simulator. Verified: all hops complete with no
    failure and the last apex passes ``target_x``."""
    from drakeslip.simulate import simulate

    angles = [float(a) for a in leg_angles]
    if not angles or not all(abs(a) < math.pi / 2 for a in angles):
        return {"verified": False, "failure": "BAD_ANGLE", "footholds": [], "hops": 0}
    sim = simulate(apex, angles, terrain, params, max_hops=len(angles), log=False)
    footholds = [float(x) for x in sim.footholds]
    failure = sim.failure.name if sim.failure is not None else None
    done = len(sim.apexes)
    passed = done > 0 and sim.apexes[-1].x >= target_x
    ok = failure is None and done == len(angles) and passed
    reason = failure or ("" if done == len(angles) else "INCOMPLETE") or ("" if passed else "SHORT_OF_TARGET")
    return {"verified": ok, "failure": reason or None, "footholds": footholds, "hops": done,
            "final_apex": list(sim.apexes[-1]) if sim.apexes else None,
            "failure_x": float(sim.failure_event.state[0]) if sim.failure_event is not None else None}


def make_problem(apex, terrain: Terrain, goal_x: float, params: SlipParams | None = None) -> Problem:
    """The planning query the suites give: the perception-window problem (window end, target) of a Planner."""
    return TrajoptPlanner().problem(apex, terrain, goal_x, params, time.perf_counter())


def optimize(problem: Problem, seed: str | np.ndarray, config: TrajoptConfig | None = None,
             true_terrain: Terrain | None = None, verify_on_drake: bool = True,
             seed_options: dict | None = None) -> dict:
    """Seed, build, solve and verify one query. ``seed`` is a seed name (or ``NAME@VARIANT`` with
    ``seed_options`` for its planner, see ``seed_footholds``) or an array of footholds; the problem's
    terrain is what the seed and the optimizer see (the perception window), ``true_terrain`` (default: the
    same) what the solution is verified on. Returns a JSON-ready record: ``converged`` (the solver found a
    locally optimal, feasible point), ``drake_ok`` (its leg angles pass ``verify``) and ``verified`` (both: a
    plan the optimizer stands by and Drake confirms). A seed that gives nothing to optimize is reported with
    ``error`` set, not raised.

    With ``config.starts`` > 1 a named seed that can propose more than one start (``MULTI_START``) is tried
    again from its next start until one is verified (converged, without Drake): the record is the last start's,
    with ``starts`` listing every start's outcome and ``seed_time_s``, ``solve_time_s`` and ``iterations``
    adding up all of them."""
    config = config or TrajoptConfig()
    n = config.starts if isinstance(seed, str) and planner_name(seed) in MULTI_START else 1
    starts = []
    for sample in range(n):
        record = _optimize_start(problem, seed, sample, config, true_terrain, verify_on_drake, seed_options)
        starts.append(record)
        if record["verified"] or (record["converged"] and not verify_on_drake):
            break
    if n == 1:
        return record
    record = dict(record)
    record["seed_time_s"] = sum(r.get("seed_time_s", 0.0) for r in starts)
    record["ode_calls"] = sum(r.get("ode_calls", 0) for r in starts)
    solved = [r for r in starts if r.get("solve_time_s") is not None]
    if solved:
        record.update(_total_cost(solved))
    record["starts"] = [{"sample": k, "error": r["error"], "converged": r["converged"], "verified": r["verified"],
                         "status": r.get("status"), "solve_time_s": r.get("solve_time_s"),
                         "iterations": r.get("iterations")} for k, r in enumerate(starts)]
    return record


def _total_cost(solves: list) -> dict:
    """Solver time and iterations added up over several solves (iterations None if any solve lacks them)."""
    iterations = [r["iterations"] for r in solves]
    return {"solve_time_s": sum(r["solve_time_s"] for r in solves),
            "iterations": None if None in iterations else sum(iterations)}


def _optimize_start(problem: Problem, seed, sample: int, config: TrajoptConfig, true_terrain, verify_on_drake,
                    seed_options):
    """One start of ``optimize``. The solver starts from the re-anchored guess (``build_guess``); when that does
    not converge and the seed did not execute as it is, it starts once more from the chained guess
    (``config.retry``). A last attempt that stops unconverged but within ``config.polish_violation`` of feasible
    (SNOPT's "numerical difficulties" or its iteration limit, typically) is restarted from its own point, with a
    fresh Hessian approximation. ``solve_time_s`` and ``iterations`` add up every attempt."""
    record = {"seed": seed if isinstance(seed, str) else "footholds", "target_x": problem.target_x,
              "converged": False, "verified": False, "error": None}
    t0 = time.perf_counter()
    try:
        if isinstance(seed, str):
            footholds, seed_calls = seed_footholds(seed, problem, config.max_hops, config.lstm_weights, sample,
                                                   seed_options)
        else:
            footholds, seed_calls = np.asarray(seed, dtype=np.float64).reshape(-1), 0
    except TrajoptError as exc:
        record.update(error=str(exc), seed_time_s=time.perf_counter() - t0)
        return record
    record["seed_time_s"] = time.perf_counter() - t0
    record["ode_calls"] = seed_calls
    footholds = footholds[:config.max_hops]
    record["seed_footholds"] = footholds.tolist()
    record["hops"] = int(footholds.size)
    try:
        segs = assign_segments(problem.terrain, footholds, config.edge_margin, problem.window_end)
    except TrajoptError as exc:
        record["error"] = str(exc)
        return record
    program = SlipTrajopt(problem.apex, problem.terrain, segs, problem.params, problem.target_x, config)
    attempts = []
    for reanchor in (True, False):
        guess = build_guess(problem.apex, footholds, segs, problem.terrain, problem.params, config.node_times(),
                            reanchor=reanchor)
        record["ode_calls"] += footholds.size  # the guess executes each foothold once on the fast step map
        if reanchor:
            record["seed_fast_ok"] = guess.fast_ok
            record["seed_fast_failure"] = guess.fast_failure
        result = program.solve(guess)
        attempts.append({"guess": "re-anchored" if reanchor else "chained", "converged": result.converged,
                         "status": result.status, "iterations": result.iterations,
                         "solve_time_s": result.solve_time_s})
        if result.converged or guess.fast_ok or not config.retry:  # (a seed that executes has one guess)
            break
    if not result.converged and 0 < config.polish_violation and result.max_violation <= config.polish_violation:
        result = program.solve(result.x)
        attempts.append({"guess": "polish", "converged": result.converged, "status": result.status,
                         "iterations": result.iterations, "solve_time_s": result.solve_time_s})
    record.update(result.summary())
    record.update(_total_cost(attempts))  # what the query cost: every attempt's solver time and iterations
    record["attempts"] = attempts
    if verify_on_drake:
        check = verify(problem.apex, result.leg_angles, true_terrain or problem.terrain, problem.params,
                       problem.target_x)
        record["drake_ok"] = bool(check["verified"])
        record["verified"] = bool(check["verified"]) and result.converged  # a plan the optimizer stands by
        record["verification"] = check
    return record


@register("trajopt")
class TrajoptPlanner(Planner):
    """The trajectory optimization as a planner: footholds from ``seed``, optimized; the plan carries the
    optimized leg angles and apexes (``plan.success`` means the solver converged, not that Drake verified).
    Its ``ode_calls`` are the seed planner's step-map calls and the initial guess's (one per hop; none are
    counted when the seed finds no plan); the collocation's own evaluations of the SLIP equations are not
    step-map calls. It does not stop at ``max_time_s``: the seed planner has its own default budget and the
    solve runs to ``config.major_iterations`` (SNOPT's "Time limit" option had no effect when tried).
    ``seed_options``: options for the seed's planner (see ``seed_footholds``)."""

    def __init__(self, seed: str = "step", config: TrajoptConfig | None = None, seed_options: dict | None = None,
                 **budget):
        super().__init__(**budget)
        self.config = config or TrajoptConfig()
        check_seed(seed, seed_options, self.config)
        self.seed, self.seed_options = seed, seed_options

    def _plan(self, problem: Problem) -> Plan:
        record = optimize(problem, self.seed, self.config, verify_on_drake=False, seed_options=self.seed_options)
        if record["error"] or not record["converged"]:
            return Plan(self.name, False, problem.target_x, ode_calls=record.get("ode_calls", 0),
                        message=f"no plan found: {record['error'] or record.get('status')}")
        seq = FootstepSequence(np.array(record["footholds"]), np.array(record["leg_angles"]),
                               np.array(record["apexes"][1:]))
        return Plan(self.name, True, problem.target_x, ode_calls=record["ode_calls"],
                    message=record.get("status", ""), sequences=[seq])
