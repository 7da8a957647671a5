"""Named settings beyond the paper, usable as planner labels with no options: ``evaluate.py --planners
lstm@ranked``, ``make_plan.py --planner lstm-guided@beyond``, a trajopt seed ``lstm-guided@expert``. Options
given for such a label replace its preset (docs/results.md has the runs behind each)."""
from __future__ import annotations

from .lstm_planner import EXPERT_WEIGHTS, RANKER_WEIGHTS, SUBCELL_WEIGHTS

PRESETS = {
    # the mode one step ahead, model trained on the goal-reaching expert and two DAgger rounds
    "lstm@dagger": {"weights": str(EXPERT_WEIGHTS), "max_steps": 1},
    # ... with the learned re-ranker's pick among its five most probable first footholds
    "lstm@ranked": {"weights": str(EXPERT_WEIGHTS), "max_steps": 1, "ranker": str(RANKER_WEIGHTS)},
    # LSTM-guided with the sub-cell model, one sampled child simulated at a time, restarted at each node's apex
    "lstm-guided@beyond": {"weights": str(SUBCELL_WEIGHTS), "lazy": True, "conditioning": "apex"},
    # the same search with the DAgger model (the trajectory optimizer's best seed)
    "lstm-guided@expert": {"weights": str(EXPERT_WEIGHTS), "lazy": True, "conditioning": "apex"},
}


def options_for(label: str, options: dict | None = None) -> dict:
    """The options ``label`` runs with: those given, else its preset's, else none."""
    return dict(options) if options else dict(PRESETS.get(label, {}))
