"""drakeslip: a SLIP hopper on uneven terrain, as a Drake hybrid system with a fast step map.

The names below load their module on first use, so ``import drakeslip`` (and so every ``drakeslip.x`` import) loads
nothing heavy, not even numpy: a script imports ``drakeslip.jobs.cli`` first, which makes Ctrl-C one line from there
on, before the libraries load.
"""
from pathlib import Path

from drakeslip.compiled import clear_when_sources_change

clear_when_sources_change(Path(__file__).parent, [Path(__file__).parent])  # before any compiled function loads

_LAZY = {
    "SlipParams": "drakeslip.params", "ApexState": "drakeslip.state", "FailureMode": "drakeslip.state",
    "StepResult": "drakeslip.state", "TERRAIN_FAMILIES": "drakeslip.terrain", "Terrain": "drakeslip.terrain",
    "ditch_world": "drakeslip.terrain", "mixed_world": "drakeslip.terrain", "step_world": "drakeslip.terrain",
    "step": "drakeslip.stepmap", "step_batch": "drakeslip.stepmap", "BatchStepResult": "drakeslip.stepmap",
    "SlipHopper": "drakeslip.slip_hopper", "simulate": "drakeslip.simulation",
    "SimulationResult": "drakeslip.simulation", "StepLengthController": "drakeslip.controller",
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
