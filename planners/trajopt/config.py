"""The optimizer's settings: the seeds it knows, the transcription, constraint margins, the objective's weights
and solver options, and the error a seed that cannot be optimized raises.

Only numpy and the standard library are imported here, so a script's ``--help`` that shows these defaults starts
no pydrake, torch or numba.

Cost (a documented trade; the terms' weights in ``ObjectiveWeights``, ``TrajoptConfig.objective``):

    J =  edge     * sum_i sum_{finite edges e of segment i} (EDGE_SCALE / (f_i - e))^2     keep off edges
       + angle    * sum_i ((theta_{i+1} - theta_i) / ANGLE_SCALE)^2                       smooth leg commands
       + speed    * sum_i ((v_{i+1} - v_i) / SPEED_SCALE)^2   (v_0: the start's speed)    steady apex speed
       - progress * (x of the last apex - x of the start) / (target - x of the start)     go far
       - stroke   * m_s / STROKE_SCALE   (m_s: least spring travel left over the plan)    keep spring travel
       - friction * m_f / FRICTION_SCALE (m_f: least mu - |x - f| / (z - h) over the plan) keep friction to spare

The scales in metres and m/s, like every length and speed setting below, are the paper's hopper's; the program
uses them in its hopper's units (``TrajoptConfig.for_hopper``: lengths times the length factor, speeds times the
speed factor, times times the time factor), so it poses the same problem for every hopper.

The edge term is (5 cm / distance)^2: large within a few cm of an edge, negligible a few decimetres away, so it
pushes footholds off edges without pulling them to segment centres. Angle and speed changes are measured in
units of 0.1 rad and 0.5 m/s; smooth commands and steady speeds are also what keeps an open-loop plan robust.
Progress is the only term that rewards distance, normalized so that reaching the target is worth 1.

The margin terms (``margins.py``; off by default, and then the program has no margin variables) maximize the
plan's least margin over every stance knot: 1 cm of spring travel (of the 20 cm stroke) or 0.1 of friction
coefficient (of mu = 0.8) is worth as much as reaching the target. Without them the plan rides its constraints
(``stroke_margin`` and ``friction_fraction``), which noisy execution breaks. The ``trajopt@robust`` preset weighs
stroke 10 and friction 1: spring travel is what bottoms out under noise (on the step suite's case 7 it raises the
least travel from 3 to 15.5 mm and the share of realistic-noise draws that complete 3 hops from 26 % to 40 %), and
stroke alone buys it with the friction margin (0.51 to 0.15 on a flat 3-hop problem; 0.38 with the friction term).
Where the least margin is set by the terrain (a drop, the start apex) the terms change little.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

SEEDS = ("cold", "heuristic", "step", "lstm", "lstm-guided")
MULTI_START = ("cold", "lstm-guided")  # seeds with more than one start: other strides, other samples
COLD_STRIDES = (0, 1, -1, 2, -2)       # the cold seed's k-th start: this many hops more than the nominal gait
COLLOCATIONS = ("chebyshev", "hermite-simpson")
EDGE_SCALE = 0.05    # [m]   distance to an edge at which the edge cost of a foothold is 1
ANGLE_SCALE = 0.1    # [rad] change in leg angle between hops that costs 1
SPEED_SCALE = 0.5    # [m/s] change in apex speed between hops that costs 1
STROKE_SCALE = 0.01  # [m]   spring travel left over the whole plan that is worth 1
FRICTION_SCALE = 0.1  # [-]  friction to spare (mu - |x - f| / (z - h)) over the whole plan that is worth 1
COLD_OVERSHOOT = 0.05  # [m] the cold seed's last foothold lands this far past the target
SEED_TOLERANCE = 0.02  # [m] a seed's hop counts as executed when it lands this close to its foothold


class TrajoptError(ValueError):
    """A seed or segment assignment that cannot be optimized (e.g. a foothold on a ditch)."""


@dataclass(frozen=True)
class ObjectiveWeights:
    """The weights of the objective's terms (the cost J of the module docstring); the margin terms are off by
    default."""

    edge: float = 1.0
    angle: float = 1.0
    speed: float = 1.0
    progress: float = 1.0
    stroke: float = 0.0
    friction: float = 0.0


# The paper's hopper's constraint margins and speed bounds: TrajoptConfig's length and speed fields left at None
# take these in the hopper's units (``TrajoptConfig.for_hopper``).
PAPER_LENGTHS = {"edge_margin": 0.03, "stroke_margin": 0.003, "clearance": 0.01, "target_margin": 0.05}
PAPER_SPEEDS = {"min_speed": 0.3, "max_speed": 6.0, "min_stance_speed": 0.05}


@dataclass(frozen=True)
class TrajoptConfig:
    """Transcription, constraint margins, cost and solver settings (the constraints are described in
    ``program``, the cost above). The margins [m] and speed bounds [m/s] left at None are the paper's hopper's
    (PAPER_LENGTHS, PAPER_SPEEDS; the values in the comments) in the planned hopper's units: ``for_hopper``."""

    collocation: str = "chebyshev"   # or "hermite-simpson"
    knots: int = 20                  # stance knots minus one (Chebyshev degree, or Hermite-Simpson segments)
    max_hops: int = 24               # a seed's footholds beyond this many are dropped (slow starts take ~20
                                     # hops to cross the 7 m horizon; 24 hops solve in ~10-30 s)
    edge_margin: float | None = None     # 0.03 m: footholds stay this far inside their segment
    friction_fraction: float = 0.95      # stance knots stay inside the cone of this fraction of mu
    stroke_margin: float | None = None   # 0.003 m: knots stay this much above min_leg_length (covers the dip
                                         # between knots at mid-stance, ~1.5 mm for 20 Chebyshev knots)
    clearance: float | None = None       # 0.01 m: body and extended foot above the terrain in flight (slow, low
                                         # hops of a Step-space seed lift the foot only 1-2 cm at apex)
    flight_samples: int = 6              # intervals per ascent and per descent checked for clearance
    target_margin: float | None = None   # 0.05 m: the last apex is planned this far past the target
    min_speed: float | None = None       # 0.3 m/s and 6 m/s: apex speed bounds
    max_speed: float | None = None
    min_stance_speed: float | None = None  # 0.05 m/s: xdot at every stance knot (a STALL below 0)
    objective: ObjectiveWeights = field(default_factory=ObjectiveWeights)
    solver: str = "snopt"            # "snopt" or "ipopt"; snopt falls back to ipopt when unavailable
    seed_model: str | None = None    # checkpoint for the lstm and lstm-guided seeds, over their presets' (a
                                     # seed's own options can name another; default: each label's own)
    solver_options: tuple = ()       # extra (name, value) pairs for the solver
    retry: bool = True               # no convergence from the re-anchored guess: try the chained one too
    starts: int = 1                  # starts per query for MULTI_START seeds, until one is verified
    polish_violation: float = 0.05   # an unconverged point this close to feasible (max violation) is solved
                                     # once more from itself (0 turns the restart off)
    major_iterations: int = 400
    optimality_tolerance: float = 1e-5
    feasibility_tolerance: float = 1e-7

    def node_times(self) -> np.ndarray:
        """Stance knot times as fractions of the stance duration (``collocation.node_times``)."""
        from planners.trajopt.collocation import node_times

        return node_times(self.collocation, self.knots)

    def for_hopper(self, units) -> "TrajoptConfig":
        """This config with every length and speed left at None set to the paper's value in the units of a hopper
        (``drakeslip.units.HopperUnits``); the settings given are kept."""
        values = {name: units.length_or(getattr(self, name), paper) for name, paper in PAPER_LENGTHS.items()}
        values.update({name: units.speed_or(getattr(self, name), paper) for name, paper in PAPER_SPEEDS.items()})
        return replace(self, **values)

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
            if getattr(self, name) is not None and not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be non-negative, got {getattr(self, name)!r}")


def as_config(value: TrajoptConfig | dict | None) -> TrajoptConfig:
    """A planner's ``config`` option as a TrajoptConfig: itself, the defaults for None, or from a dict of its fields
    with ``objective`` a dict of ObjectiveWeights fields (the JSON form a preset or ``--options`` gives)."""
    if value is None or isinstance(value, TrajoptConfig):
        return value or TrajoptConfig()
    fields = dict(value)
    if isinstance(fields.get("objective"), dict):
        fields["objective"] = ObjectiveWeights(**fields["objective"])
    return TrajoptConfig(**fields)
