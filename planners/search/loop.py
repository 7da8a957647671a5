"""One search of a planning problem on the one best-first loop (``planners.core.best_first``): compiled with the
core's expansions, run as Python with the planners' Python ones."""
from __future__ import annotations

import numpy as np

from planners.base import Budget, Problem
from planners.core.best_first import ADMITTED, Limits, python_best_first
from planners.core.searches import SEARCHES, compiled_search
from planners.core.tree import NO_LIMIT
from planners.search.tree import REEXPAND_PENALTY, STOPS, SearchResult, SearchTree


def search(problem: Problem, expansion, admission, n_sequences: int, budget: Budget, target=None) -> SearchResult:
    """The best-first search of ``problem`` with ``expansion`` and ``admission``: compiled for an expansion that is a
    compiled record, as Python for one that is a Python object (its admission then a record or a Python object); its
    time is added to ``problem.timing``. ``target``: what a goal passes (``planners.core.best_first``), the problem's
    ``target_x`` when None; a search on a height map gives its ``SpatialTarget``."""
    limits = Limits(int(n_sequences), int(budget.max_nodes),
                    NO_LIMIT if budget.max_ode_calls is None else int(budget.max_ode_calls), float(problem.deadline),
                    REEXPAND_PENALTY * problem.units.length)
    loop = compiled_search(expansion) if type(expansion) in SEARCHES else python_best_first
    target = float(problem.target_x) if target is None else target
    found = loop(expansion, admission, np.array(problem.apex, dtype=np.float64), target, limits)
    problem.timing.add(found.slots)
    return SearchResult(tree_of(problem.apex, found), int(found.ode_calls), int(found.expansions), STOPS[found.stop])


def tree_of(root_apex, found) -> SearchTree:
    """The ``SearchTree`` of a search's arrays (``planners.core.best_first.Searched``)."""
    parent, angle, foothold, apex, cost, depth = (a[:found.size] for a in found.tree)
    return SearchTree(tuple(root_apex), parent.tolist(), angle.tolist(), foothold.tolist(),
                      list(map(tuple, apex.tolist())), cost.tolist(), depth.tolist(), found.goals.tolist(),
                      found.expanded.tolist())


class AdmitAll:
    """The admission of a search run as Python that checks no node."""

    def admit(self, state, tree, node, slots):
        return ADMITTED, 0, state


ADMIT_ALL = AdmitAll()
