"""The paper's reported results, Tables II (ditch suite) and III (step suite): success rate, ODE calls and planning
time per planning call of each of its planners, for ``examples/paper_tables.py`` and ``examples/plot_results.py``
to set beside ours. Only the standard library is imported, so a script's ``--help`` stays fast."""
from __future__ import annotations

# suite family -> the paper's planner name -> (success %, ODE calls per plan, t_plan [s])
TABLES = {
    "ditch": {"heuristic": (24, 0, 2e-5), "angle": (58.6, 22661, 0.15), "step": (86.6, 30857, 0.29),
              "lstm": (56, 0, 0.007), "lstm-guided": (84, 4885, 0.04)},
    "step": {"heuristic": (56, 0, 2e-5), "angle": (60, 27021, 0.15), "step": (85, 41146, 0.34),
             "lstm": (49, 0, 0.007), "lstm-guided": (96, 6932, 0.04)},
}
TITLES = {"ditch": "Table II (ditch suite)", "step": "Table III (step suite)"}


def reported(family: str | None, planner: str) -> tuple | None:
    """The paper's (success %, ODE calls, t_plan [s]) for the planner named ``planner`` on the ``family`` suite;
    None where the paper has no such number (a planner it did not run, such as ``trajopt``, or another suite)."""
    return TABLES.get(family, {}).get(planner)
