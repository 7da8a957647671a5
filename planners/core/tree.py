"""A search's tree and frontier as arrays that grow by doubling, and the children an expansion adds to them.

A ``Tree`` holds every node: node 0 the root (the start apex, no foothold), node i > 0 the child of ``parent[i]``
by the leg ``angle[i]`` that lands on ``foothold[i]`` and reaches ``apex[i]`` (x, z, xdot), with its queue
``cost[i]`` and ``depth[i]``. The frontier is a binary heap of (cost, node) pairs in two arrays, ordered as
Python's ``heapq`` orders the tuples (cost, then node). ``Children`` are what one expansion of a node found: their
leg angles, footholds, next apexes and queue keys, the step-map calls it took, whether a hop went past the
perception window (``beyond``), whether the node has candidates left (``more``) and which child, if any, is a goal
already (``goal``)."""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from drakeslip.compiled import compiled
from planners.core.clock import now

Tree = namedtuple("Tree", ["parent", "angle", "foothold", "apex", "cost", "depth"])
# the frontier: a binary heap of ``size`` (key, node) pairs in two arrays
Frontier = namedtuple("Frontier", ["keys", "ids", "size"])
Children = namedtuple("Children", ["angles", "footholds", "apexes", "keys", "ode_calls", "beyond", "more", "goal"])
# the node cost's weights: progress to the target, speed (times the hopper's time unit), isolation
Scoring = namedtuple("Scoring", ["target_x", "progress", "speed", "isolation"])

# stop codes (``planners.search.tree.STOPS`` names them), "go on", and the unlimited step-map budget
GOALS, EXHAUSTED, NODES, ODE_CALLS, TIME = range(5)
GO_ON = -1
NO_LIMIT = -1
CAPACITY = 256   # the nodes a new tree and frontier have room for before they first grow
NO_GOAL = -1     # ``Children.goal`` when none of the children is a goal yet


@compiled()
def child_costs(footholds, apexes, isolation, scoring):
    """The queue key of each child: progress * |x - target| + speed * |xdot| + isolation * D (the paper's h)."""
    keys = np.empty(footholds.shape[0])
    for j in range(footholds.shape[0]):
        keys[j] = (scoring.progress * abs(footholds[j] - scoring.target_x) + scoring.speed * abs(apexes[j, 2])
                   + scoring.isolation * isolation[j])
    return keys


@compiled(inline="always")
def budget_stop(expansions, max_nodes, ode_calls, max_ode_calls, deadline):
    """The search's termination conditions, checked before each expansion: the stop code of the first budget
    spent (nodes, step-map calls, the wall-clock deadline), or GO_ON."""
    if expansions >= max_nodes:
        return NODES
    if max_ode_calls != NO_LIMIT and ode_calls >= max_ode_calls:
        return ODE_CALLS
    if now() >= deadline:
        return TIME
    return GO_ON


@compiled()
def tree_arrays(capacity):
    """A tree with room for ``capacity`` nodes, none set."""
    return Tree(np.empty(capacity, np.int64), np.empty(capacity), np.empty(capacity), np.empty((capacity, 3)),
                np.empty(capacity), np.empty(capacity, np.int64))


@compiled()
def new_tree(root):
    """A tree holding the root apex ``root`` (x, z, xdot) alone (no parent, angle or foothold; cost inf, depth 0), with
    room for CAPACITY nodes."""
    tree = tree_arrays(np.int64(CAPACITY))
    tree.parent[0], tree.angle[0], tree.foothold[0], tree.cost[0], tree.depth[0] = -1, math.nan, math.nan, math.inf, 0
    tree.apex[0, 0], tree.apex[0, 1], tree.apex[0, 2] = root[0], root[1], root[2]
    return tree


@compiled(inline="always")
def passes(tree, node, target_x):
    """Whether ``node``'s foothold passes the target: the search's goal test."""
    return tree.foothold[node] >= target_x


@compiled()
def grown(a, need):
    """``a`` with room for ``need`` entries along its first axis (a copy twice as large when needed; the new entries
    are not set)."""
    if need <= a.shape[0]:
        return a
    out = np.empty((max(2 * a.shape[0], need),) + a.shape[1:], a.dtype)
    copy_head(out, a, a.shape[0])
    return out


@compiled()
def copy_head(dst, src, n):
    """``dst[:n] = src[:n]`` for C-contiguous arrays of equal row shape, as one flat loop: a slice assignment of
    arrays with more than one axis compiles numba's shape check and its message, several seconds a signature."""
    flat_dst, flat_src = dst.reshape(-1), src.reshape(-1)
    for i in range(n * (src.size // max(src.shape[0], 1))):
        flat_dst[i] = flat_src[i]


@compiled(inline="always")
def reserve(tree, size, extra):
    """``tree`` with room for ``extra`` nodes after its first ``size`` (a copy twice as large when needed), whatever
    the widths of its node's arrays: the planar tree's and the spatial one's (``planners.core.spatial_tree``)."""
    need = size + extra
    if need <= tree.parent.shape[0]:
        return tree
    return Tree(grown(tree.parent, need), grown(tree.angle, need), grown(tree.foothold, need), grown(tree.apex, need),
                grown(tree.cost, need), grown(tree.depth, need))


@compiled()
def new_frontier():
    """An empty frontier with room for CAPACITY nodes."""
    return Frontier(np.empty(CAPACITY), np.empty(CAPACITY, np.int64), np.int64(0))


@compiled(inline="always")
def _before(keys, ids, a, b):
    return keys[a] < keys[b] or (keys[a] == keys[b] and ids[a] < ids[b])


@compiled(inline="always")
def heap_push(frontier, key, node):
    """The frontier with (key, node) pushed (its arrays grown when full)."""
    keys, ids, size = frontier
    if size == keys.shape[0]:
        keys2, ids2 = np.empty(2 * size + 16), np.empty(2 * size + 16, np.int64)
        copy_head(keys2, keys, size)
        copy_head(ids2, ids, size)
        keys, ids = keys2, ids2
    i = size
    keys[i], ids[i] = key, node
    while i > 0:
        up = (i - 1) // 2
        if not _before(keys, ids, i, up):
            break
        keys[i], keys[up] = keys[up], keys[i]
        ids[i], ids[up] = ids[up], ids[i]
        i = up
    return Frontier(keys, ids, size + 1)


@compiled(inline="always")
def heap_pop(frontier):
    """Remove the least (key, node); returns its node and the frontier after."""
    keys, ids, size = frontier
    node = ids[0]
    size -= 1
    keys[0], ids[0] = keys[size], ids[size]
    i = 0
    while True:
        left, least = 2 * i + 1, i
        if left < size and _before(keys, ids, left, least):
            least = left
        if left + 1 < size and _before(keys, ids, left + 1, least):
            least = left + 1
        if least == i:
            return node, Frontier(keys, ids, size)
        keys[i], keys[least] = keys[least], keys[i]
        ids[i], ids[least] = ids[least], ids[i]
        i = least


@compiled()
def add_children(tree, size, node, children, frontier):
    """Add a node's children to the tree, each with its queue key, and push them on the frontier; returns the tree,
    its size and the frontier."""
    k = children.angles.shape[0]
    tree = reserve(tree, size, k)
    for j in range(k):
        i = size + j
        tree.parent[i], tree.angle[i], tree.foothold[i] = node, children.angles[j], children.footholds[j]
        tree.cost[i], tree.depth[i] = children.keys[j], tree.depth[node] + 1
        tree.apex[i, 0], tree.apex[i, 1], tree.apex[i, 2] = (children.apexes[j, 0], children.apexes[j, 1],
                                                              children.apexes[j, 2])
        frontier = heap_push(frontier, children.keys[j], i)
    return tree, size + k, frontier
