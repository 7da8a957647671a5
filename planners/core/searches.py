"""The core's searches: the one best-first loop (``planners.core.best_first``) compiled for each pairing of a compiled
expansion with an admission, and the pairing a search's records ask for (``compiled_search``)."""
from __future__ import annotations

from drakeslip.compiled import compiled

from planners.core.best_first import specialized
from planners.core.grid import NO_STATE, GridExpansion, expand_grid
from planners.core.pruned import PrunedExpansion, expand_pruned, merge_admit, start_stage
from planners.core.robust import robust_admit, start_flights
from planners.core.sampled import SampledExpansion, expand_sampled, new_state
from planners.core.spatial_grid import SpatialExpansion, admit_every, expand_spatial_grid, start_spatial
from planners.core.spatial_sampled import SpatialSampledExpansion, expand_spatial_sampled, start_sampled_spatial
from planners.core.spatial_tree import SPATIAL_TREE


@compiled(inline="always")
def start_grid(expansion, admission, root):
    """Step-space's search's start: the grid keeps no state, the robust admission its particles' flights."""
    return NO_STATE, start_flights(admission)


@compiled(inline="always")
def start_sampled(expansion, admission, root):
    """LSTM-guided sampling's search's start: no draws yet, the robust admission's particles' flights."""
    return new_state(expansion.width), start_flights(admission)


GRID_SEARCH = specialized(start_grid, expand_grid, robust_admit)
SAMPLED_SEARCH = specialized(start_sampled, expand_sampled, robust_admit)
PRUNED_SEARCH = specialized(start_stage, expand_pruned, merge_admit)
SPATIAL_GRID_SEARCH = specialized(start_spatial, expand_spatial_grid, admit_every, SPATIAL_TREE)
SPATIAL_SAMPLED_SEARCH = specialized(start_sampled_spatial, expand_spatial_sampled, admit_every, SPATIAL_TREE)
SEARCHES = {GridExpansion: GRID_SEARCH, SampledExpansion: SAMPLED_SEARCH, PrunedExpansion: PRUNED_SEARCH,
            SpatialExpansion: SPATIAL_GRID_SEARCH, SpatialSampledExpansion: SPATIAL_SAMPLED_SEARCH}


def compiled_search(expansion):
    """The compiled loop for ``expansion``'s record (its admission: the robust one, or the pruned stage's)."""
    return SEARCHES[type(expansion)]
