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
