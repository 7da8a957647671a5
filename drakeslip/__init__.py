"""drakeslip: a SLIP hopper on uneven terrain, as a Drake hybrid system with a fast step map.

The names below load their module on first use, so ``import drakeslip`` does not start pydrake, numba or torch.
"""
from drakeslip.params import SlipParams
from drakeslip.state import ApexState, FailureMode, StepResult
from drakeslip.terrain import TERRAIN_FAMILIES, Terrain, ditch_world, mixed_world, step_world

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
