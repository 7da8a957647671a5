"""The planning core: the search planners' per-node work compiled (numba) in one loop.

A best-first search (``search.py``) over footstep trees held as growing arrays (``tree.py``), its nodes expanded
by Step-space's grid (``grid.py``) or by the footstep model's samples (``sampled.py``, with the model's recurrent
step compiled in ``model.py``), each child aimed by the compiled controller (``drakeslip.fast_controller``) and
flown by the compiled step map (``drakeslip.fast_step``), and the robust levels' particles flown when a node is
popped. The Python planners (planners/search/step_space.py, planners/learned/lstm_guided.py) set up a problem's
arrays and read back the tree; the core makes the same tree, node for node, as the Python search
(planners/search/tree.py ``best_first``), which still serves the Drake step map. ``clock.py`` times the parts of
a call (``Timing``)."""
