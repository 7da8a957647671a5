"""The compiled search's tree and frontier as arrays that grow by doubling.

A tree is the tuple (parent, angle, foothold, apex (N, 3), cost, depth), node 0 the root, as
``planners.search.tree.SearchTree`` holds them in lists. The frontier is a binary heap of (cost, node) pairs in two
arrays, ordered as Python's ``heapq`` orders the tuples (cost, then node), so the two pop the same sequence."""
from __future__ import annotations

import math

import numpy as np

from drakeslip.compiled import compiled
from planners.core.clock import now

# stop codes (planners/core/search.py names them), "go on", and the unlimited step-map budget
GOALS, EXHAUSTED, NODES, ODE_CALLS, TIME = range(5)
GO_ON = -1
NO_LIMIT = -1
CAPACITY = 256   # the nodes a new tree and frontier have room for before they first grow


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
    """A tree's arrays with room for ``capacity`` nodes, none set."""
    return (np.empty(capacity, np.int64), np.empty(capacity), np.empty(capacity), np.empty((capacity, 3)),
            np.empty(capacity), np.empty(capacity, np.int64))


@compiled()
def new_tree(root_x, root_z, root_xdot):
    """A tree holding the root alone (no parent, angle or foothold; cost inf, depth 0), with room for CAPACITY
    nodes."""
    tree = tree_arrays(np.int64(CAPACITY))
    parent, angle, foothold, apex, cost, depth = tree
    parent[0], angle[0], foothold[0], cost[0], depth[0] = -1, math.nan, math.nan, math.inf, 0
    apex[0, 0], apex[0, 1], apex[0, 2] = root_x, root_z, root_xdot
    return tree


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
    """``tree`` with room for ``extra`` nodes after its first ``size`` (a copy twice as large when needed)."""
    parent, angle, foothold, apex, cost, depth = tree
    if size + extra <= parent.shape[0]:
        return tree
    capacity = max(2 * parent.shape[0], size + extra)
    larger = tree_arrays(capacity)
    copy_head(larger[0], parent, size)
    copy_head(larger[1], angle, size)
    copy_head(larger[2], foothold, size)
    copy_head(larger[3], apex, size)
    copy_head(larger[4], cost, size)
    copy_head(larger[5], depth, size)
    return larger


@compiled(inline="always")
def _before(keys, ids, a, b):
    return keys[a] < keys[b] or (keys[a] == keys[b] and ids[a] < ids[b])


@compiled(inline="always")
def heap_push(keys, ids, size, key, node):
    """Push (key, node); returns the heap's arrays (grown when full) and its new size."""
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
    return keys, ids, size + 1


@compiled(inline="always")
def heap_pop(keys, ids, size):
    """Remove the least (key, node); returns its node and the heap's new size."""
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
            return node, size
        keys[i], keys[least] = keys[least], keys[i]
        ids[i], ids[least] = ids[least], ids[i]
        i = least


@compiled(inline="always")
def add_children(tree, size, node, angles, footholds, apexes, d, target_x, weights, keys, ids, heap):
    """Add a node's children to the tree, each with its cost, and push them on the frontier; returns the tree,
    its size and the frontier."""
    k = angles.shape[0]
    tree = reserve(tree, size, k)
    parent, angle, foothold, apex, cost, depth = tree
    progress, speed, spread = weights
    for j in range(k):
        i = size + j
        c = progress * abs(footholds[j] - target_x) + speed * abs(apexes[j, 2]) + spread * d[j]
        parent[i], angle[i], foothold[i], cost[i], depth[i] = node, angles[j], footholds[j], c, depth[node] + 1
        apex[i, 0], apex[i, 1], apex[i, 2] = apexes[j, 0], apexes[j, 1], apexes[j, 2]
        keys, ids, heap = heap_push(keys, ids, heap, c, i)
    return tree, size + k, keys, ids, heap
