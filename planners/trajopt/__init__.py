"""Multi-hop trajectory optimization of the SLIP in Drake's ``MathematicalProgram``, warm-started by a seed.

A seed (``cold``, ``heuristic``, ``step``, ``lstm`` or ``lstm-guided``, or ``NAME@VARIANT`` of one, see
``seeds.seed_footholds``) proposes N footholds. They fix the discrete part of the problem, the flat run of cells
("segment") each hop lands on, and the optimizer moves the footholds within their segments, together with
everything continuous about the N hops: leg angles, fall times, stance trajectories and apexes.

The initial guess executes the seed's footholds with the controller on the fast step map; the solver is SNOPT
(IPOPT when SNOPT is unavailable, or asked for); every solution is checked by simulating its leg angles open loop
on the Drake hybrid simulator on the true terrain. ``optimize`` runs one query end to end and returns a
JSON-ready record; ``planners.make("trajopt", seed=...)`` is the same as a planner.

Modules, in the order a query uses them:

* ``config``: the seeds, settings (``TrajoptConfig``), the objective's weights and scales, ``TrajoptError``;
* ``seeds``: footholds from a seed's planner (or the cold gait);
* ``segments``: the terrain's flat runs of cells and the one each foothold lands on;
* ``guess``: the initial guess from the seed's footholds;
* ``collocation``: the stance's knot times and collocation defects;
* ``autodiff``: the SLIP equations on dual numbers, for the defects and their Jacobian;
* ``program``: the N-hop ``MathematicalProgram`` (transcription, constraints, cost) and its solve;
* ``solve``: ``optimize`` (seed, build, solve, retry, polish, further starts) and ``verify`` on Drake;
* ``planner``: ``TrajoptPlanner`` and ``make_problem``.

Nothing is imported here, so ``planners.trajopt.config`` loads without pydrake, torch or numba.
"""
