"""Step-space on a height map: the best-first search over a square grid of desired footholds around each apex,
aimed by the spatial controller and flown by the spatial step map (``planners.core.spatial_grid``), on the one
best-first loop (``planners.search.loop``). ``StepSpacePlanner.plan`` runs it when its terrain is a HeightMap.

Each node's children are the grid's footholds within reach (hundreds: the grid is two-dimensional) that are solid,
clear of any face or hole within the edge margin, inside the known window, reached with the leg inside the friction
cone, and whose hop lands within the tolerance and keeps the least speed. A child's queue key is the planar one in
the plane: its foothold's distance to the target, its speed, and its isolation (how many of its grid neighbours
failed). A search that finds nothing is retried on each finer fallback grid. With a robustness (``step@robust``), a
child is kept only where every robust particle flies it too (``robust_particles``), at the robustness's sigmas and
then RELAXED_SIGMAS on the first grid, before the nominal searches (``levels``)."""
from __future__ import annotations

import functools
from dataclasses import dataclass, fields, replace

import numpy as np

from drakeslip.compiled import compiling
from drakeslip.noise import MIN_FRICTION
from drakeslip.params import SlipParams
from drakeslip.spatial.heightmap import HeightMap
from drakeslip.spatial.stepmap import step_batch3d

from planners.base import Budget, Plan
from planners.core.spatial_grid import NO_STATE, RobustParticles, SpatialExpansion, SpatialGrid
from planners.core.spatial_tree import SpatialScoring
from planners.search.loop import search
from planners.search.spatial_problem import SpatialProblem
from planners.search.robust import Robustness
from planners.search.tree import ISOLATION_AT_FAILURE, MIN_SPEED, Attempts, CostWeights

# The paper's hopper's settings [m] (a search uses them in its hopper's lengths, as every planner does):
SPACING = 0.05              # the foothold grid: the height-map families' 5 cm cells
FALLBACK_SPACINGS = (0.025,)
TOLERANCE = 0.02            # a hop must land this close to its desired foothold
REACH_PAD = 0.1             # added to the reach disk's radius: the drift over uneven ground is bounded loosely
EDGE_MARGIN = 0.03          # no face or hole within this of a foothold, in any direction
FRICTION_MARGIN = 0.99      # the leg stays strictly inside the friction cone
# The robust check's particles (``robust_particles``): how many, the seed of their corners, and the standard deviations
# a relaxed level settles for when no sequence survives the robustness's own
PARTICLES = 8
PARTICLE_SEED = 0
RELAXED_SIGMAS = 1.0
MAP_ROBUSTNESS = ("noise", "sigmas", "friction_loss")   # the Robustness fields the map search reads


def check_fast_step_map(planner) -> None:
    """ValueError in one line unless ``planner`` flies its hops on the compiled step map: on a map the compiled core
    flies every hop, and the Drake step map is a planar option."""
    if getattr(planner, "step_map", "fast") != "fast":
        raise ValueError(f"the {planner.name!r} planner plans on a height map without step_map='drake'")


def check_map_robustness(robustness: Robustness | None) -> None:
    """ValueError, in one line, naming each field of ``robustness`` other than MAP_ROBUSTNESS that differs from
    ``Robustness()``'s: those are the planar robust search's (``planners.search.robust``), and on a map they would be
    ignored without a word."""
    if robustness is None:
        return
    default = Robustness()
    changed = [f"{f.name}={getattr(robustness, f.name)!r}" for f in fields(Robustness)
               if f.name not in MAP_ROBUSTNESS and getattr(robustness, f.name) != getattr(default, f.name)]
    if changed:
        kind = "is a planar search setting" if len(changed) == 1 else "are planar search settings"
        raise ValueError(f"robustness {', '.join(changed)} {kind}: on a height map the robust particles fly every hop "
                         f"of a sequence at the robustness's sigmas, then at {RELAXED_SIGMAS:g} sigma, and the search "
                         f"reads only its {', '.join(MAP_ROBUSTNESS)}")


@dataclass(frozen=True)
class SpatialStepSettings:
    """Step-space's settings on a height map; None takes the paper's hopper's value in the hopper's units.
    ``robustness``: its MAP_ROBUSTNESS fields only, any other changed is refused (``check_map_robustness``).
    ``safe_hops``: where no search finds a sequence, the plan holds the safest branch they grew (``Plan.safe_hops``)."""

    spacing: float | None = None
    fallback_spacing: tuple | None = None
    tolerance: float | None = None
    edge_margin: float | None = None
    min_speed: float | None = None
    cost_weights: CostWeights = CostWeights()
    n_sequences: int = 1
    stance_steps: int = 60
    robustness: Robustness | None = None
    fallback_nominal: bool = True
    safe_hops: bool = False

    def __post_init__(self):
        check_map_robustness(self.robustness)   # before any search: a setting the map search ignores is refused


NOMINAL = RobustParticles(np.zeros((0, 7)), np.zeros((0, 6)))   # a nominal search's: none


def robust_particles(robustness: Robustness, params: SlipParams, sigmas: float) -> RobustParticles:
    """PARTICLES robots at random corners (seeded: the same every call) of the robustness's noise at ``sigmas``
    standard deviations, in the hopper's units: the apex told off in x, y, z, xdot and ydot, the leg's pitch and roll
    off, the spring and the mass off by the model's half-ranges, and the friction lower by the robustness's
    ``friction_loss`` (its noise's friction half-range when None), for all of them."""
    noise = robustness.noise.for_hopper(params)
    signs = np.random.default_rng(PARTICLE_SEED).choice([-1.0, 1.0], size=(PARTICLES, 9))
    x, z, v = noise.apex
    errors = signs[:, :7] * sigmas * np.array([x, x, z, v, v, noise.leg_angle, noise.leg_angle])
    loss = noise.friction if robustness.friction_loss is None else robustness.friction_loss
    rows = [replace(params, stiffness=params.stiffness * (1 + signs[j, 7] * noise.stiffness),
                    mass=params.mass * (1 + signs[j, 8] * noise.mass),
                    friction=max(params.friction - loss, MIN_FRICTION)).as_array() for j in range(PARTICLES)]
    return RobustParticles(np.ascontiguousarray(errors), np.ascontiguousarray(np.array(rows)))


def grid_spacings(units, settings: SpatialStepSettings) -> list:
    """The grids' spacings [m] a search tries in turn: ``spacing``, then each ``fallback_spacing`` (the paper's
    hopper's SPACING and FALLBACK_SPACINGS in the hopper's lengths where None)."""
    spacings = [units.length_or(settings.spacing, SPACING)]
    return spacings + list(settings.fallback_spacing if settings.fallback_spacing is not None
                           else (s * units.length for s in FALLBACK_SPACINGS))


def levels(settings: SpatialStepSettings, params: SlipParams) -> list:
    """(label, particles) of each round of searches, the most robust first: the robustness's sigmas, then
    RELAXED_SIGMAS, then (``fallback_nominal``) none; a nominal planner's one round."""
    r = settings.robustness
    if r is None:
        return [("", NOMINAL)]
    rounds = [(f"robust at {k:g} sigma, ", robust_particles(r, params, k)) for k in dict.fromkeys((r.sigmas,
                                                                                                   RELAXED_SIGMAS))]
    return rounds + ([("", NOMINAL)] if settings.fallback_nominal else [])

def grid_of(problem: SpatialProblem, settings: SpatialStepSettings, spacing: float) -> SpatialGrid:
    units = problem.units
    x_min, x_max, y_min, y_max = problem.window
    return SpatialGrid(float(spacing), REACH_PAD * units.length,
                       units.length_or(settings.edge_margin, EDGE_MARGIN),
                       FRICTION_MARGIN * problem.params.max_leg_angle,
                       units.length_or(settings.tolerance, TOLERANCE), units.speed_or(settings.min_speed, MIN_SPEED),
                       float(x_min), float(x_max), float(y_min), float(y_max),
                       ISOLATION_AT_FAILURE * units.length, np.int64(settings.stance_steps))


def scoring_of(problem: SpatialProblem, weights: CostWeights) -> SpatialScoring:
    return SpatialScoring(float(problem.target[0]), float(problem.target[1]), float(weights.progress),
                          float(weights.speed * problem.units.time), float(weights.isolation))


@functools.cache
def warm_up() -> None:
    """Load the compiled spatial step map once per process, so start-up is not charged to a plan's time."""
    with compiling():
        step_batch3d((0.0, 0.0, 1.0, 1.0, 0.0), [(0.1, 0.0)], HeightMap.flat())


def plan_step_space(problem: SpatialProblem, settings: SpatialStepSettings, budget: Budget, name: str) -> Plan:
    """The Step-space plan of ``problem``: the search on the grid of ``spacing``, then each fallback grid, each within
    the node budget, until one finds a sequence."""
    return search_step_space(problem, settings, budget, name)[0]


def search_step_space(problem: SpatialProblem, settings: SpatialStepSettings, budget: Budget, name: str) -> tuple:
    """(``plan_step_space``'s plan, the tree of its last search): the tree's paths are the dataset of the spatial
    footstep model (planners/learned/training/spatial_dataset.py)."""
    warm_up()
    spacings = grid_spacings(problem.units, settings)
    searches = []
    for label, particles in levels(settings, problem.params):
        # a robust round searches the first grid: its footholds that every particle survives are not in bands a
        # finer grid would find
        for spacing in spacings if particles is NOMINAL else spacings[:1]:
            searches.append((f"{label}{spacing * 100:g} cm grid", SpatialExpansion(
                grid_of(problem, settings, spacing), problem.height_map.ground(), problem.params.as_array(),
                scoring_of(problem, settings.cost_weights), particles), budget))
    return run_searches(problem, searches, settings, name)


def run_searches(problem: SpatialProblem, searches, settings: SpatialStepSettings, name: str):
    """Run the (label, expansion, budget) ``searches`` in turn, each within its budget, until one finds a sequence or
    the time runs out (``planners.search.tree.Attempts``: the planar planners' accounting, safe hops included where
    ``settings.safe_hops``): (the plan, the last search's tree)."""
    tried = Attempts(name, problem.target_x, settings.safe_hops, target_y=problem.target[1])
    for label, expansion, budget in searches:
        with compiling():
            result = search(problem, expansion, NO_STATE, settings.n_sequences, budget, problem.reach)
        if tried.ended(label, result):
            break
    return tried.plan(), result.tree

