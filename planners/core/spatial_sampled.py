"""LSTM-guided search's expansion on a height map, compiled: the spatial footstep model reads the node's patch and
its branch's past footholds and ranks the patch's cells; a node is expanded in tiers, one each time the search comes
back to it (``Children.more``): the points (``split`` x ``split`` a cell) of its most probable cells that hold one that
is solid, clear of edges and inside the window, up to ``tiers[0]`` cells, then the next up to ``tiers[1]``, and so
on. They are aimed and flown as Step-space's candidates are (``planners.core.spatial_grid``) and the successful ones
are the node's children; a tier none of whose hops succeeds hands over to the next at once. The model is run in the
core (``planners.core.spatial_model``), so a node costs one small forward pass and a few dozen hops instead of the
grid's hundreds (its logits are kept for its next tier), and a node's wider tier is flown only where its first leads
nowhere: one search, not a search per width."""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import types
from numba.typed import Dict

from drakeslip.compiled import compiled

from planners.core.clock import MODEL, now
from planners.core.spatial_grid import NO_STATE, children_from, fly_candidates, foothold_height
from planners.core.spatial_model import cell_points, logits_of, node_view
from planners.core.tree import Children

# The expansion: Step-space's grid settings (its margins, tolerance, window; not its spacing), the map, the hopper,
# the node cost's scoring, the model's view (``ViewSettings``) and arrays (``SpatialModelArrays``), the target (x, y)
# the model is told, the cells flown by each tier (cumulative, int64), the points a cell's side is split into, and
# the robust check's particles (``planners.core.spatial_grid.RobustParticles``)
SpatialSampledExpansion = namedtuple("SpatialSampledExpansion", ["grid", "ground", "params", "scoring", "patch_view",
                                                                 "model", "target_x", "target_y", "tiers",
                                                                 "split", "particles"])


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
def model_candidates(a, logits, e, first, last):
    """The admissible points, (x, y, z) rows, the most probable cell's first, of the cells ranked ``first`` to
    ``last`` (exclusive) among the cells that hold one: a cell over a hole or an edge holds no candidate and does not
    count, so a node on stepping stones flies the stones the model ranks first, not the holes around them."""
    n = logits.shape[0]
    order = np.argsort(-logits.reshape(-1))
    grid, ground = e.grid, e.ground
    out = np.empty((e.split * e.split * max(last - first, 0), 3))
    k = cells = 0
    for r in range(n * n):
        if cells == last:
            break
        points = cell_points(a, order[r] // n, order[r] % n, ground, e.params, e.patch_view, e.split)
        held = 0
        for q in range(points.shape[0]):
            x, y = points[q, 0], points[q, 1]
            h = foothold_height(x, y, grid, ground)
            if math.isnan(h):
                continue
            held += 1
            if cells >= first:
                out[k, 0], out[k, 1], out[k, 2] = x, y, h
                k += 1
        if held > 0:
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
    """The guided expansion of ``node`` (``planners.core.best_first.expand``): the children of its next tier that has
    any (the module doc), whether a tier is left, and the search's state (``state``: node -> tiers done, and node ->
    the model's logits of a node with a tier left, so that a node the search comes back to is not read again)."""
    e = expansion
    done, kept = state
    a = (tree.apex[node, 0], tree.apex[node, 1], tree.apex[node, 2], tree.apex[node, 3], tree.apex[node, 4])
    tier = done[node] if node in done else 0
    if tier > 0:
        logits = kept.pop(node)
    else:
        t0 = now()
        history, n_history = branch_footholds(tree, node, e.patch_view.history)
        patch, features, past = node_view(a, history, n_history, (e.target_x, e.target_y), e.ground, e.params,
                                          e.patch_view)
        logits = logits_of(patch, features, past, e.model)
        slots[MODEL] += now() - t0
    calls = 0
    while True:
        targets = model_candidates(a, logits, e, e.tiers[tier - 1] if tier > 0 else 0, e.tiers[tier])
        ok, angles, apexes, flown = fly_candidates(a, targets, e, slots)
        calls += flown
        tier += 1
        if ok.any() or tier == e.tiers.shape[0]:
            break
    done[node] = tier
    if tier < e.tiers.shape[0]:
        kept[node] = logits
    d = sibling_isolation(targets, ok, e.patch_view.cell / e.split, e.grid.at_failure)
    found = children_from(targets, ok, angles, apexes, d, calls, e.scoring)
    return Children(found.angles, found.footholds, found.apexes, found.keys, found.ode_calls, found.beyond,
                    tier < e.tiers.shape[0], found.goal), state


@compiled(inline="always")
def start_sampled_spatial(expansion, admission, root):
    """The guided search's start: no node expanded yet (node -> tiers done, node -> logits kept), no admission
    state."""
    return (Dict.empty(types.int64, types.int64), Dict.empty(types.int64, types.float64[:, ::1])), NO_STATE
