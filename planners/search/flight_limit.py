"""The compiled kernel of the energy argument's flight limit (``planners.search.energy_graph.CellGraph.fly_limit``),
kept apart so that importing the energy graph does not load numba."""
from __future__ import annotations

import numpy as np

from drakeslip.compiled import compiled


# many parameters: the cells' arrays and the query, as compiled code reads them
@compiled()
def first_failing_pair(a, bound, lo, hi, h, rank, levels, H, slack):
    """``CellGraph.fly_limit``: over the cells q with hi_q > a and lo_q < bound, in order, the least
    max(lo_q, cap) over the pairs p <= q with cap = max(lo_p, a) + 2 (H - min(h_p, h_q)) + slack < hi_q. For each
    q only the least cap counts, and it is the least of two: over p as low as q or lower, max(lo_p, a) + 2 (H - h_p)
    (a prefix minimum over the height ranks ``rank``, 0 to ``levels`` - 1, kept in a Fenwick tree); over p as high
    or higher, the least max(lo_p, a) (another, over the ranks reversed) + 2 (H - h_q). Each is computed as the
    pairwise formula computes it, so the limit is the same number."""
    low = np.full(levels + 1, np.inf)    # Fenwick tree of minima of max(lo_p, a) + 2 (H - h_p) by rank, ascending
    high = np.full(levels + 1, np.inf)   # Fenwick tree of minima of max(lo_p, a) by rank, descending
    best = np.inf
    for q in range(lo.size):
        if not (hi[q] > a and lo[q] < bound):
            continue
        start = max(lo[q], a)
        i = rank[q] + 1
        while i <= levels:
            low[i] = min(low[i], start + 2.0 * (H - h[q]))
            i += i & -i
        i = levels - rank[q]
        while i <= levels:
            high[i] = min(high[i], start)
            i += i & -i
        cap = np.inf
        i = rank[q] + 1
        while i > 0:
            cap = min(cap, low[i])
            i -= i & -i
        first = np.inf
        i = levels - rank[q]
        while i > 0:
            first = min(first, high[i])
            i -= i & -i
        cap = min(cap, first + 2.0 * (H - h[q])) + slack
        if cap < hi[q]:
            best = min(best, max(lo[q], cap))
    return best
