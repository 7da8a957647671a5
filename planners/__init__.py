"""Footstep planners behind one interface: ``planners.make(label, **options).plan(apex, terrain, goal_x, params)``
returns a ``Plan``.

Families (OMPL-style, each in its own subpackage): search (``heuristic``, ``angle`` Angle-space, ``step``
Step-space), learned (``lstm``, the CNN+LSTM model's mode, and ``lstm-guided``, Step-space search sampling it), and
trajectory optimization (``trajopt``, warm-started by another planner's footholds). ``available()`` lists the
names, ``labels()`` the presets too (e.g. ``lstm@paper``, the paper's literal settings)."""
from planners.base import Budget, FootstepSequence, Plan, Planner
from planners.registry import PRESETS, available, labels, make, make_planners, options_for, planner_name, register

__all__ = ["make", "make_planners", "available", "labels", "planner_name", "options_for", "register", "PRESETS",
           "Plan", "Planner", "Budget", "FootstepSequence"]
