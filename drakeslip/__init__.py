"""drakeslip: a SLIP hopper on uneven terrain, as a Drake hybrid system with a fast step map."""
from .params import SlipParams
from .state import ApexState, FailureMode, StepResult
from .terrain import Terrain, ditch_world, mixed_world, step_world, TERRAIN_FAMILIES
from .stepmap import BatchStepResult, step, step_batch

__all__ = ["SlipParams", "ApexState", "FailureMode", "StepResult", "Terrain", "ditch_world", "step_world",
           "mixed_world", "TERRAIN_FAMILIES", "step", "step_batch", "BatchStepResult"]
