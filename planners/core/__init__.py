"""The planning core: what the search planners run in compiled code, importing nothing above it.

The one best-first loop (``best_first.py``) over a tree and frontier held as growing arrays (``tree.py``), with the
expansion and the admission plugged in by record type: Step-space's grid (``grid.py``), the footstep model's samples
(``sampled.py``, with the model's forward pass in ``model.py``), the pruned last stage's merge cells (``pruned.py``),
and the robust levels' particles (``robust.py``, their flights in ``particles.py``); each child is aimed by the
compiled controller (``drakeslip.fast_controller``) and flown by the compiled step map (``drakeslip.fast_step``).
The same loop runs as Python for the planners' Python expansions (the Drake step map's, Angle-space's), and the
planners in planners/search/ and planners/learned/ build the records and read back the tree
(``planners.search.loop``). ``ground.py`` holds the level and edge tests of a point on a height map, ``clock.py``
the clock that times the parts of a call (``planners.base.Timing``)."""
