"""The learned planners on a height map: the spatial footstep model (planners/learned/spatial_model.py) ranks the
patch ahead of each node and the search flies the points of its most probable cells (``planners.core.spatial_sampled``)
instead of Step-space's whole grid: first each cell's centre (the model's 10 cm cells, one point each: on open ground
and stairs a plan needs no finer choice, and a node costs a few hops), then points as far apart as the points of
Step-space's grids, 5 cm, then 2.5 cm, where a foothold on a small stone needs the finer ones.
``LSTMGuidedPlanner.plan_on_map`` searches at each spacing in turn, each node expanded in tiers of its most probable
cells (``map_cells``: 4, then 8), then (``map_grid_fallback``) Step-space's own searches; ``LSTMPlanner.plan_on_map``
follows the model's most probable cell (one cell a node, little backtracking): the paper's LSTM planner on a map."""
from __future__ import annotations

import functools
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from planners.base import Budget, Plan
from planners.checkpoints import SPATIAL_WEIGHTS
from planners.core.spatial_model import view_of
from planners.core.spatial_sampled import SpatialSampledExpansion
from planners.search.spatial_problem import SpatialProblem, spatial_problem
from planners.search.spatial_step import (NOMINAL, SPACING, SpatialExpansion, SpatialStepSettings,
                                          check_fast_step_map, grid_of, grid_spacings, levels, run_searches,
                                          scoring_of, warm_up)
from planners.search.tree import CostWeights


@functools.lru_cache(maxsize=4)
def spatial_model(path: str):
    """(the model's config, its arrays for the compiled pass) of a weights file, loaded and checked once;
    FileNotFoundError where there is none (not cached: asked again on the next call)."""
    from planners.learned.spatial_model import load_spatial_checkpoint

    if not Path(path).is_file():
        raise FileNotFoundError(path)

    model, _ = load_spatial_checkpoint(path)
    return model.config, model.arrays()


# many parameters: the problem, the search's settings, the model, the tiers, the spacing and the particles
def sampled_expansion(problem: SpatialProblem, settings: SpatialStepSettings, model_path: str, tiers, spacing: float,
                      particles=NOMINAL) -> SpatialSampledExpansion:
    """The guided expansion flying the model cells of ``tiers`` (cumulative counts), their points about ``spacing``
    apart."""
    config, arrays = spatial_model(str(model_path))
    view = view_of(config, problem.params)
    grid = grid_of(problem, settings, problem.units.length_or(settings.spacing, SPACING))
    return SpatialSampledExpansion(grid, problem.height_map.ground(), problem.params.as_array(),
                                   scoring_of(problem, settings.cost_weights), view, arrays, float(problem.target[0]),
                                   float(problem.target[1]), np.array(tiers, np.int64),
                                   np.int64(max(1, round(view.cell / spacing))), particles)


# many parameters: the planner's options that apply on a map, and its budget and name
def plan_guided(problem: SpatialProblem, settings: SpatialStepSettings, model_path, tiers, grid_fallback: bool,
                budget: Budget, name: str) -> Plan:
    """The guided search at the model's cell, then at each of Step-space's grid spacings in turn (a robust level at
    the cell and Step-space's first spacing only, as Step-space's at its first), at each robustness level of
    ``settings`` (``planners.search.spatial_step.levels``), each node expanded in the ``tiers`` of model cells, within
    ``budget``; then, where ``grid_fallback``, Step-space's grids as ``step`` searches them, within its node budget at
    least (a guided node flies a few hops, a grid node hundreds: the guided budget is no grid search's)."""
    warm_up()
    spacings = grid_spacings(problem.units, settings)
    config, _ = spatial_model(str(model_path))
    cell = view_of(config, problem.params).cell
    guided = [cell] + [s for s in spacings if s < cell]   # a cell's centre, then the grids' spacings within it
    cells = ", then ".join(map(str, tiers))
    searches = [(f"{label}{cells} model cells a node at {spacing * 100:.3g} cm",
                 sampled_expansion(problem, settings, model_path, tiers, spacing, particles), budget)
                for label, particles in levels(settings, problem.params)
                for spacing in (guided if particles is NOMINAL else guided[:2])]
    if grid_fallback:   # Step-space's grids in turn, nominal, as its own last round
        grid_budget = replace(budget, max_nodes=max(budget.max_nodes, Budget.max_nodes))
        for spacing in spacings:
            searches.append((f"{spacing * 100:g} cm grid", SpatialExpansion(
                grid_of(problem, settings, spacing), problem.height_map.ground(), problem.params.as_array(),
                scoring_of(problem, settings.cost_weights), NOMINAL), grid_budget))
    return run_searches(problem, searches, settings, name)[0]


# many parameters: Planner.plan_on_map's inputs and the planner's options that apply on a map
def plan_on_map(planner, apex, height_map, goal, params, tiers, grid_fallback: bool, budget: Budget) -> Plan:
    """A learned planner's plan on a height map (module doc), timed as ``Planner.plan`` times a plan."""
    t0 = time.perf_counter()
    check_fast_step_map(planner)
    model_path = getattr(planner, "map_model", None) or SPATIAL_WEIGHTS
    try:   # loaded once a process: a plan of a few milliseconds does not read the disk
        spatial_model(str(model_path))
    except FileNotFoundError:
        raise ValueError(f"the {planner.name!r} planner's map model {model_path} does not exist") from None
    problem = spatial_problem(apex, height_map, goal, params, planner.horizon, t0, budget.max_time_s)
    settings = SpatialStepSettings(getattr(planner, "spacing", None), getattr(planner, "fallback_spacing", None),
                                   getattr(planner, "tolerance", None), getattr(planner, "edge_margin", None),
                                   getattr(planner, "min_speed", None), getattr(planner, "cost_weights", CostWeights()),
                                   getattr(planner, "n_sequences", 1), robustness=getattr(planner, "robustness", None),
                                   fallback_nominal=getattr(planner, "fallback_nominal", True),
                                   safe_hops=getattr(planner, "safe_hops", False))
    plan = plan_guided(problem, settings, model_path, tiers, grid_fallback, budget, planner.name)
    plan.time_s = time.perf_counter() - t0
    problem.timing.total = plan.time_s
    plan.timing = problem.timing.record()
    return plan
