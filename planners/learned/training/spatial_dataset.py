"""The spatial footstep model's dataset: Step-space's search trees on random height maps, flown in the
receding-horizon loop on the compiled step map.

Each case draws a map of a family (the families alternating), its difficulty, a start and a goal from the case's own
generator (``SpatialDatasetConfig.seed`` and its index), and runs the loop (``planners.spatial_loop``) with
Step-space recording every search it makes. Every node a found plan passes through is a sample: the model's inputs
at that node (``planners.core.spatial_model.node_view``, the node's own branch as its history) and its label, the
distribution over the patch's cells that puts ``CHOSEN`` on the cell of the plan's next foothold and the rest evenly
on the cells of every foothold the search found viable from the node. Shards of ``cases_per_shard`` cases are
written atomically as ``.npz`` files; a rerun makes only the missing ones."""
from __future__ import annotations

import numpy as np

from drakeslip.jobs.files import atomic_write
from drakeslip.params import SlipParams
from drakeslip.spatial.families import height_map_family
from drakeslip.units import units_of

from planners.base import Budget
from planners.core.spatial_model import ViewSettings, cell_of_point, node_view, view_of
from planners.learned.training.config import SpatialDatasetConfig
from planners.replanning import ClosedLoopConfig
from planners.search.spatial_problem import spatial_problem
from planners.search.spatial_step import SpatialStepSettings, search_step_space
from planners.spatial_loop import MapCase, run_map_case

CHOSEN = 0.5   # the label's weight on the plan's own next foothold; the rest is spread over the viable ones


def case_of(cfg: SpatialDatasetConfig, index: int, params: SlipParams) -> MapCase:
    """Case ``index``: its map, start and goal, all from the generator seeded by (seed, index)."""
    rng = np.random.default_rng([cfg.seed, index])
    family = cfg.families[index % len(cfg.families)]
    length = units_of(params).length
    height_map = height_map_family(family)(int(rng.integers(1 << 31)), float(rng.uniform(0.0, 1.0)), length)
    x, y = -1.0 * length, float(rng.uniform(-0.5, 0.5)) * length
    speed, heading = float(rng.uniform(0.8, 3.0)) * units_of(params).speed, float(rng.uniform(-0.3, 0.3))
    z = float(height_map.height_at(x, y)) + float(rng.uniform(0.75, 1.05)) * length
    goal = (10.0 * length, float(rng.uniform(-1.0, 1.0)) * length)
    return MapCase(f"{family}-{index}", height_map, (x, y, z, speed * np.cos(heading), speed * np.sin(heading)), goal)


# The expert's budget: Step-space's nodes, which give the same plans on any machine; the time limit is only a safety
# net, far above any call (a starved machine at the planners' 60 s would cut calls short and write another dataset)
EXPERT_BUDGET = Budget(max_time_s=600.0)


class RecordingStepSpace:
    """Step-space on a height map that keeps the samples of every plan it finds."""

    name = "step"

    def __init__(self, view: ViewSettings, budget: Budget = EXPERT_BUDGET):
        self.view, self.budget, self.samples = view, budget, []

    def plan(self, apex, window, goal, params):
        import time

        problem = spatial_problem(apex, window, goal, params, None, time.perf_counter(), self.budget.max_time_s)
        plan, tree = search_step_space(problem, SpatialStepSettings(), self.budget, self.name)
        if plan.success:
            self.samples.extend(tree_samples(tree, tree.goals[0], problem, self.view))
        return plan


def tree_samples(tree, goal: int, problem, view: ViewSettings) -> list:
    """(patch, features, past, label) of every node on the way to ``goal`` (module doc)."""
    ground, p = problem.height_map.ground(), problem.params.as_array()
    path = [0] + tree.branch(goal)
    parents = np.asarray(tree.parent)
    samples = []
    for k, node in enumerate(path[:-1]):
        apex = tuple(tree.apex[node])
        label = np.zeros((view.size, view.size))
        viable = [i for i in np.flatnonzero(parents == node)]
        for i in viable:
            a, c = cell_of_point(apex, tree.foothold[i][0], tree.foothold[i][1], ground, p, view)
            if a >= 0:
                label[a, c] += (1.0 - CHOSEN) / len(viable)
        a, c = cell_of_point(apex, tree.foothold[path[k + 1]][0], tree.foothold[path[k + 1]][1], ground, p, view)
        if a < 0 or label.sum() <= 0:
            continue
        label[a, c] += CHOSEN
        branch = np.array([tree.foothold[i][:2] for i in path[1:k + 1]], dtype=np.float64).reshape(-1, 2)
        patch, features, past = node_view(apex, branch, len(branch), problem.target, ground, p, view)
        samples.append((patch, features, past, label / label.sum()))
    return samples


def make_shard(cfg: SpatialDatasetConfig, shard: int, params: SlipParams) -> dict:
    """The arrays of shard ``shard``: its cases' samples stacked."""
    view = view_of(cfg.model, params)
    planner = RecordingStepSpace(view)
    first = shard * cfg.cases_per_shard
    for index in range(first, min(first + cfg.cases_per_shard, cfg.cases)):
        run_map_case(planner, case_of(cfg, index, params), params, ClosedLoopConfig(backend="fast"))
    n, size = len(planner.samples), cfg.model.size
    arrays = {"patch": np.zeros((n, 2, size, size), np.float32), "features": np.zeros((n, 4), np.float32),
              "past": np.zeros((n, cfg.model.history, 3), np.float32), "label": np.zeros((n, size * size), np.float32)}
    for k, (patch, features, past, label) in enumerate(planner.samples):
        arrays["patch"][k], arrays["features"][k], arrays["past"][k] = patch, features, past
        arrays["label"][k] = label.reshape(-1)
    return arrays


def write_shard(path, arrays: dict) -> None:
    with atomic_write(path) as f:
        np.savez_compressed(f, **arrays)
