"""The search tree on a height map: ``planners.core.tree``'s arrays with a spatial node, for the one best-first loop.

Node i > 0 is the child of ``parent[i]`` by the leg (pitch, roll) ``angle[i]`` that lands on ``foothold[i]`` (x, y,
z) and reaches ``apex[i]`` (x, y, z, xdot, ydot). The frontier, the heap, the budget and the growth (``reserve``) are
the planar tree's; the loop is bound to ``SPATIAL_TREE``'s functions (``planners.core.best_first.specialized``)."""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from drakeslip.compiled import compiled
from planners.core.tree import CAPACITY, Tree, heap_push, reserve

# Where a search on a height map goes: a goal is reached by a hop whose way, from the foothold before it to its own,
# passes within ``radius`` of (x, y); a target on the way by a foothold past the line through (x, y) across the
# ``heading`` (hx, hy) (a unit vector) within ``half_width`` of it (``reaches``; a negative half width: no line, a
# radius of 0: no disk)
SpatialTarget = namedtuple("SpatialTarget", ["x", "y", "hx", "hy", "half_width", "radius"])
# the node cost's weights: progress to the target, speed (times the hopper's time unit), isolation
SpatialScoring = namedtuple("SpatialScoring", ["target_x", "target_y", "progress", "speed", "isolation"])
ANGLES, FOOTHOLD, APEX = 2, 3, 5   # the widths of a node's leg command, foothold and apex


@compiled()
def tree_arrays(capacity):
    """A spatial tree with room for ``capacity`` nodes, none set."""
    return Tree(np.empty(capacity, np.int64), np.empty((capacity, ANGLES)), np.empty((capacity, FOOTHOLD)),
                np.empty((capacity, APEX)), np.empty(capacity), np.empty(capacity, np.int64))


@compiled()
def new_tree(root):
    """A tree holding the root apex ``root`` (x, y, z, xdot, ydot) alone, with room for CAPACITY nodes."""
    tree = tree_arrays(np.int64(CAPACITY))
    tree.parent[0], tree.cost[0], tree.depth[0] = -1, math.inf, 0
    for k in range(ANGLES):
        tree.angle[0, k] = math.nan
    for k in range(FOOTHOLD):
        tree.foothold[0, k] = math.nan
    for k in range(APEX):
        tree.apex[0, k] = root[k]
    return tree


@compiled()
def add_children(tree, size, node, children, frontier):
    """Add a node's children to the tree, each with its queue key, and push them on the frontier."""
    k = children.angles.shape[0]
    tree = reserve(tree, size, k)
    for j in range(k):
        i = size + j
        tree.parent[i], tree.cost[i], tree.depth[i] = node, children.keys[j], tree.depth[node] + 1
        for c in range(ANGLES):
            tree.angle[i, c] = children.angles[j, c]
        for c in range(FOOTHOLD):
            tree.foothold[i, c] = children.footholds[j, c]
        for c in range(APEX):
            tree.apex[i, c] = children.apexes[j, c]
        frontier = heap_push(frontier, children.keys[j], i)
    return tree, size + k, frontier


@compiled()
def reaches(px, py, fx, fy, target):
    """Whether the hop from (px, py) (the foothold before it; for a plan's first hop the body at its apex) to the
    foothold (fx, fy) reaches ``target`` (a ``SpatialTarget``): its way passes within the target's radius of its point,
    or the foothold lands past its line within its half width. The way is the segment between the footholds, which
    the body passes over: a hop that passes the goal aside and lands beyond it has not been there."""
    wx, wy = fx - px, fy - py
    along = wx * wx + wy * wy
    share = 0.0 if along <= 0.0 else min(1.0, max(0.0, ((target.x - px) * wx + (target.y - py) * wy) / along))
    cx, cy = px + share * wx - target.x, py + share * wy - target.y
    if cx * cx + cy * cy <= target.radius * target.radius:
        return True
    dx, dy = fx - target.x, fy - target.y
    return dx * target.hx + dy * target.hy >= 0.0 and abs(dy * target.hx - dx * target.hy) <= target.half_width


@compiled(inline="always")
def passes(tree, node, target):
    """Whether the hop to ``node`` reaches the target (``reaches``, from its parent's foothold, or from the root's
    apex for the root's children): the search's goal test."""
    parent = tree.parent[node]
    if parent <= 0:
        px, py = tree.apex[0, 0], tree.apex[0, 1]
    else:
        px, py = tree.foothold[parent, 0], tree.foothold[parent, 1]
    return reaches(px, py, tree.foothold[node, 0], tree.foothold[node, 1], target)


@compiled()
def child_costs(footholds, apexes, isolation, scoring):
    """The queue key of each child: progress * |foothold - target| + speed * |horizontal velocity| + isolation * D."""
    keys = np.empty(footholds.shape[0])
    for j in range(footholds.shape[0]):
        distance = math.sqrt((footholds[j, 0] - scoring.target_x) ** 2 + (footholds[j, 1] - scoring.target_y) ** 2)
        speed = math.sqrt(apexes[j, 3] ** 2 + apexes[j, 4] ** 2)
        keys[j] = scoring.progress * distance + scoring.speed * speed + scoring.isolation * isolation[j]
    return keys


SPATIAL_TREE = {"new_tree": new_tree, "add_children": add_children, "passes": passes}
