"""The footstep model's configuration, as a dataclass importable without torch."""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class ModelConfig:
    n_cells: int = 110        # perception window: 11 m in 10 cm cells
    hidden: int = 110         # LSTM units per layer (the paper)
    layers: int = 2
    channels: int = 8         # CNN feature maps
    kernel: int = 7           # 7x1 filters (the paper)
    apex_features: int = 3
    subcells: int = 1         # output bins per cell (1: the paper's model)

    @property
    def n_bins(self) -> int:
        return self.n_cells * self.subcells


@dataclass(frozen=True)
class SpatialModelConfig:
    """The spatial footstep model (planners/learned/spatial_model.py): its patch (cells per side and their size in the
    paper's hopper's metres; the planner uses them in its hopper's lengths), the past footholds it reads, the
    convolutions' channels and the history LSTM's units."""

    size: int = 12
    cell: float = 0.1
    history: int = 3
    channels: int = 6
    hidden: int = 16
