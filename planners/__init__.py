"""Footstep planners behind one interface: ``planners.make(name, **options).plan(apex, terrain, goal_x, params)``
returns a ``Plan``. Registered: ``heuristic``, ``angle`` (Angle-space search), ``step`` (Step-space search),
``lstm`` (the CNN+LSTM model's modes), ``lstm-guided`` (Step-space search sampling the LSTM), ``trajopt``
(multi-hop trajectory optimization in Drake, warm-started by another planner's footholds)."""
from .base import Budget, FootstepSequence, Plan, Planner
from .registry import available, make, planner_name, register, takes
from .search import CostWeights, SearchTree
from . import heuristic, angle_space, step_space, lstm_planner, lstm_guided, trajopt  # noqa: E402,F401  (registers the planners)
from .angle_space import AngleSpacePlanner
from .heuristic import HeuristicPlanner
from .step_space import StepSpacePlanner

__all__ = ["make", "available", "planner_name", "register", "takes", "Plan", "Planner", "Budget", "FootstepSequence", "CostWeights",
           "SearchTree", "AngleSpacePlanner", "StepSpacePlanner", "HeuristicPlanner"]
