"""Footstep planners behind one interface: ``planners.make(label, **options).plan(apex, terrain, goal_x, params)``
returns a ``Plan``.

Families (OMPL-style, each in its own subpackage): search (``heuristic``, ``angle`` Angle-space, ``step``
Step-space), learned (``lstm``, the CNN+LSTM model's mode, and ``lstm-guided``, Step-space search sampling it), and
trajectory optimization (``trajopt``, warm-started by another planner's footholds). ``available()`` lists the
names, ``labels()`` the presets too (e.g. ``lstm@paper``, the paper's literal settings)."""
from pathlib import Path

import drakeslip
from drakeslip.compiled import clear_when_sources_change

# The compiled core inlines drakeslip's compiled step map and controller: its cache is kept to both packages' sources.
clear_when_sources_change(Path(__file__).parent, [Path(__file__).parent, Path(drakeslip.__file__).parent])

from planners.base import Budget, FootstepSequence, Plan, Planner  # noqa: E402
from planners.registry import (PRESETS, available, labels, make, make_planners, options_for,  # noqa: E402
                               planner_name, register)

__all__ = ["make", "make_planners", "available", "labels", "planner_name", "options_for", "register", "PRESETS",
           "Plan", "Planner", "Budget", "FootstepSequence"]
