"""Direct collocation of one stance: knot times, the defects of ``dynamics.stance_derivatives`` with the foot
pinned at (f, h), their sparsity, and the leg length at the interior knots.

Chebyshev (pseudospectral: the degree-K polynomial through Chebyshev-Gauss-Lobatto knots has the model's
derivative at every knot after the first) or Hermite-Simpson on K uniform segments.

Why Chebyshev with 20 knots by default: the solution is checked open loop, and the SLIP's apex return map at a
fixed leg angle is unstable (apex-height eigenvalue about 2-3 at these gaits), so a transcription error grows
about 3x per hop. Hermite-Simpson with 10 segments is off by ~1e-5 m per hop, which ruins a 12-hop open-loop
plan; Chebyshev with 20 knots agrees with Drake's simulator to ~5e-10 m per hop (``tests/test_trajopt.py``).

One definition of the SLIP: the defects evaluate the numba-compiled ``drakeslip.dynamics`` functions' own Python
source on dual numbers (``autodiff.py``), so the defects of a whole stance and their Jacobian come from one
vectorized pass.
"""
from __future__ import annotations

import numpy as np

from drakeslip import SlipParams
from drakeslip import dynamics as dyn
from planners.trajopt.autodiff import Dual, generic


def node_times(collocation: str, knots: int) -> np.ndarray:
    """Stance knot times as fractions of the stance duration: Chebyshev-Gauss-Lobatto points, or uniform."""
    if collocation == "chebyshev":
        return 0.5 * (1.0 - np.cos(np.pi * np.arange(knots + 1) / knots))
    return np.linspace(0.0, 1.0, knots + 1)


def differentiation_matrix(tau: np.ndarray) -> np.ndarray:
    """D with (D @ values)[i] = derivative at tau[i] of the polynomial through (tau, values) (barycentric)."""
    diff = tau[:, None] - tau[None, :]
    np.fill_diagonal(diff, 1.0)
    w = 1.0 / diff.prod(axis=1)
    D = (w[None, :] / w[:, None]) / diff
    np.fill_diagonal(D, 0.0)
    np.fill_diagonal(D, -D.sum(axis=1))
    return D


def stance_defects(collocation: str, K: int, params: SlipParams, h: float):
    """Collocation defects of one stance on a foot at height h, over (S (K+1, 4) row-major, f, T): 4 blocks
    (x, z, xdot, zdot) of K defects, from the shared ``dynamics.stance_derivatives``. Chebyshev: the
    degree-K polynomial through the knots has the model's derivative at knots 1..K (spectral accuracy: the
    stance is smooth); Hermite-Simpson: the compressed form on K uniform segments."""
    p = params.as_array()
    F = generic(dyn.stance_derivatives)
    rows = np.arange(K + 1) * 4
    D = differentiation_matrix(node_times(collocation, K))[1:]

    def chebyshev(v):
        comp = [v[rows + j] for j in range(4)]
        f, T = v[4 * (K + 1)], v[4 * (K + 1) + 1]
        d = F(*comp, f, h, p)
        return Dual.concat([D @ c - T * dc[1:] for c, dc in zip(comp, d)])

    def hermite_simpson(v):
        comp = [v[rows + j] for j in range(4)]
        f, T = v[4 * (K + 1)], v[4 * (K + 1) + 1]
        s0, s1 = [c[:-1] for c in comp], [c[1:] for c in comp]
        d0, d1 = F(*s0, f, h, p), F(*s1, f, h, p)
        dt = T / K
        sm = [0.5 * (a + b) + dt / 8.0 * (da - db) for a, b, da, db in zip(s0, s1, d0, d1)]
        dm = F(*sm, f, h, p)
        return Dual.concat([b - a - dt / 6.0 * (da + 4.0 * dc + db)
                            for a, b, da, dc, db in zip(s0, s1, d0, dm, d1)])

    return chebyshev if collocation == "chebyshev" else hermite_simpson


def defect_sparsity(collocation: str, K: int) -> list:
    """(row, column) of the collocation defects' structural nonzeros (see ``stance_defects``): defect (j, k)
    involves state j on the knots it couples, every state at knot k, the foot and the duration."""
    cheb = collocation == "chebyshev"
    pattern = set()
    for j in range(4):
        for k in range(K):
            row = j * K + k
            knots = range(K + 1) if cheb else (k, k + 1)
            pattern.update((row, 4 * n + j) for n in knots)
            for n in ((k + 1,) if cheb else (k, k + 1)):
                pattern.update((row, 4 * n + c) for c in range(4))
            pattern.update({(row, 4 * (K + 1)), (row, 4 * (K + 1) + 1)})
    return sorted(pattern)


def interior_leg_lengths(K: int, h: float):
    """Leg length (``dynamics.stance_leg_length``) at the interior stance knots, over their (x, z) and the foot."""
    leg_len = generic(dyn.stance_leg_length)

    def lengths(v):
        return leg_len(v[0:2 * (K - 1):2], v[1:2 * (K - 1):2], v[2 * (K - 1)], h)

    return lengths
