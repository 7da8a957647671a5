"""drakeslip: a SLIP hopper on uneven terrain, as a Drake hybrid system with a fast step map.

The names below load their module on first use, so ``import drakeslip`` does not start pydrake, numba or torch.
"""
from pathlib import Path

from drakeslip.compiled import clear_when_sources_change

clear_when_sources_change(Path(__file__).parent, [Path(__file__).parent])  # before any compiled function loads

from drakeslip.params import SlipParams  # noqa: E402
from drakeslip.state import ApexState, FailureMode, StepResult  # noqa: E402
from drakeslip.terrain import TERRAIN_FAMILIES, Terrain, ditch_world, mixed_world, step_world  # noqa: E402

_LAZY = {
    "step": "drakeslip.stepmap", "step_batch": "drakeslip.stepmap", "BatchStepResult": "drakeslip.stepmap",
    "SlipHopper": "drakeslip.hopper", "simulate": "drakeslip.simulation", "SimulationResult": "drakeslip.simulation",
    "StepLengthController": "drakeslip.controller",
}

__all__ = ["SlipParams", "ApexState", "FailureMode", "StepResult", "Terrain", "ditch_world", "step_world",
           "mixed_world", "TERRAIN_FAMILIES", *_LAZY]


def __getattr__(name: str):
    if name not in _LAZY:
        raise AttributeError(f"module 'drakeslip' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(_LAZY[name]), name)
    globals()[name] = value
    return value
