"""The committed weights of the learned planners (planners/weights/), by what each model is."""
from __future__ import annotations

from pathlib import Path

WEIGHTS_DIR = Path(__file__).with_name("weights")
# The paper's CNN+LSTM, trained on Angle-space search trees (Table I): examples/generate_dataset.py, train_lstm.py
PAPER_WEIGHTS = WEIGHTS_DIR / "lstm_paper.pt"
# 2.5 cm output bins, trained on Step-space trees with soft labels over each step's viable set
SUBCELL_WEIGHTS = WEIGHTS_DIR / "lstm_subcell.pt"
# trained on the goal-reaching expert's rollouts and two DAgger rounds, for the one-step mode planner
EXPERT_WEIGHTS = WEIGHTS_DIR / "lstm_expert.pt"
# the learned re-ranker of the expert model's most probable first footholds: examples/train_ranker.py
RANKER_WEIGHTS = WEIGHTS_DIR / "ranker.pt"
# the spatial footstep model that guides the planners on height maps: examples/train_spatial_model.py
SPATIAL_WEIGHTS = WEIGHTS_DIR / "spatial_footstep.pt"
