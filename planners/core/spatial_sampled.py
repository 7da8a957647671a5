"""LSTM-guided search's expansion on a height map, compiled: the spatial footstep model reads the node's patch and
its branch's past footholds and ranks the patch's cells; the points (``split`` x ``split`` a cell) of each of the
``width`` most probable cells that hold one that is solid, clear of edges and inside the window are aimed and flown
as Step-space's candidates are (``planners.core.spatial_grid``), and the successful ones are the node's children.
The model is run in the core (``planners.core.spatial_model``), so a node costs one small forward pass and a few
dozen hops instead of the grid's hundreds."""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from drakeslip.compiled import compiled

from planners.core.clock import MODEL, now
from planners.core.spatial_grid import NO_STATE, children_from, fly_candidates, foothold_height
from planners.core.spatial_model import cell_points, logits_of, node_view

# The expansion: Step-space's grid settings (its margins, tolerance, window; not its spacing), the map, the hopper,
# the node cost's scoring, the model's view (``ViewSettings``) and arrays (``SpatialModelArrays``), the target
# (x, y) the model is told, the cells flown per node, the points a cell's side is split into, and the robust check's
# particles (``planners.core.spatial_grid.RobustParticles``)
SpatialSampledExpansion = namedtuple("SpatialSampledExpansion", ["grid", "ground", "params", "scoring", "patch_view",
                                                                 "model", "target_x", "target_y", "width", "split",
                                                                 "particles"])


@compiled(inline="always")
def branch_footholds(tree, node, depth):
    """The last ``depth`` footholds (x, y) of ``node``'s branch, oldest first, and how many there are."""
    out = np.empty((depth, 2))
    k = 0
    i = node
    while i > 0 and k < depth:
        out[depth - 1 - k, 0], out[depth - 1 - k, 1] = tree.foothold[i, 0], tree.foothold[i, 1]
        k += 1
        i = tree.parent[i]
    return out[depth - k:], k


@compiled(inline="always")
def sampled_candidates(a, logits, e):
    """The admissible points of the ``width`` most probable cells that hold one, (x, y, z) rows, the most probable
    first: a cell over a hole or an edge gives no candidate and does not count, so a node on stepping stones flies
    the stones the model ranks first, not the holes around them."""
    n = logits.shape[0]
    order = np.argsort(-logits.reshape(-1))
    grid, ground = e.grid, e.ground
    out = np.empty((e.split * e.split * e.width, 3))
    k = cells = 0
    for r in range(n * n):
        if cells == e.width:
            break
        points = cell_points(a, order[r] // n, order[r] % n, ground, e.params, e.patch_view, e.split)
        first = k
        for q in range(points.shape[0]):
            x, y = points[q, 0], points[q, 1]
            h = foothold_height(x, y, grid, ground)
            if math.isnan(h):
                continue
            out[k, 0], out[k, 1], out[k, 2] = x, y, h
            k += 1
        if k > first:
            cells += 1
    return out[:k]


@compiled(inline="always")
def sibling_isolation(targets, ok, spacing, at_failure):
    """D of each candidate: the mean over the other candidates within two ``spacing`` of it (its neighbours in its
    cell and the next) of ``spacing`` where that one succeeded and ``at_failure`` where it did not; a point with no
    such neighbour scores ``at_failure``."""
    m = targets.shape[0]
    d = np.empty(m)
    for k in range(m):
        total, count = 0.0, 0
        for j in range(m):
            if j != k and math.hypot(targets[j, 0] - targets[k, 0], targets[j, 1] - targets[k, 1]) < 2.0 * spacing:
                total += spacing if ok[j] else at_failure
                count += 1
        d[k] = total / count if count else at_failure
    return d


@compiled()
def expand_spatial_sampled(expansion, state, tree, size, node, slots):
    """The guided expansion of ``node`` (``planners.core.best_first.expand``): its children and the state (none)."""
    e = expansion
    a = (tree.apex[node, 0], tree.apex[node, 1], tree.apex[node, 2], tree.apex[node, 3], tree.apex[node, 4])
    t0 = now()
    history, n_history = branch_footholds(tree, node, e.patch_view.history)
    patch, features, past = node_view(a, history, n_history, (e.target_x, e.target_y), e.ground, e.params, e.patch_view)
    logits = logits_of(patch, features, past, e.model)
    slots[MODEL] += now() - t0
    targets = sampled_candidates(a, logits, e)
    ok, angles, apexes, calls = fly_candidates(a, targets, e, slots)
    d = sibling_isolation(targets, ok, e.patch_view.cell / e.split, e.grid.at_failure)
    return children_from(targets, ok, angles, apexes, d, calls, e.scoring), state


@compiled(inline="always")
def start_sampled_spatial(expansion, admission, root):
    return NO_STATE, NO_STATE
