"""The margin-maximizing part of the N-hop program (``objective.stroke`` and ``objective.friction`` of the config).

With a positive weight, the program gets one more decision variable per margin, bounded by every stance knot of
every hop, and the cost rewards it (max-min: the whole plan keeps at least that margin):

* m_s, spring travel left: ``dynamics.stroke_left`` = leg length - ``min_leg_length`` >= m_s at the interior
  stance knots (the touchdown and liftoff knots are at rest length);
* m_f, friction to spare: mu - |x - f| / (z - h) >= m_f at every stance knot, written (mu - m_f)(z - h) >= |x - f|
  (z - h > 0 in stance). This is the ``friction`` margin ``verification/margins.py`` reports, in units of mu.

A weight of 0 adds nothing, so the default program is unchanged.
"""
from __future__ import annotations

import numpy as np

from drakeslip import dynamics as dyn
from planners.trajopt.autodiff import Dual, dual_constraint
from planners.trajopt.collocation import interior_leg_lengths
from planners.trajopt.config import FRICTION_SCALE, STROKE_SCALE


def add_margins(program) -> dict:
    """Add the margin variables with a positive weight, their constraints (groups ``stroke_margin`` and
    ``friction_margin``) and their rewards to a ``SlipTrajopt`` under construction; returns {name: variable}."""
    w, prog, params, K = program.config.objective, program.prog, program.params, program.K
    L_min, mu = params.min_leg_length, params.friction
    margins = {}
    if w.stroke:
        m = margins["stroke"] = prog.NewContinuousVariables(1, "m_stroke")[0]
        prog.AddBoundingBoxConstraint(0.0, params.leg_length - L_min, m)
        for i, seg in enumerate(program.segs):
            variables = np.concatenate([program.S[i][1:K, :2].reshape(-1), [program.foot[i], m]])
            binding = prog.AddConstraint(dual_constraint(_stroke_left(K, seg.height), K - 1), np.full(K - 1, L_min),
                                         np.full(K - 1, np.inf), variables)
            binding.evaluator().SetGradientSparsityPattern(
                [(k, c) for k in range(K - 1) for c in (2 * k, 2 * k + 1, 2 * (K - 1), 2 * (K - 1) + 1)])
            program.groups.setdefault("stroke_margin", []).append(binding)
        prog.AddLinearCost(-w.stroke / (STROKE_SCALE * program.units.length) * m)
    if w.friction:
        m = margins["friction"] = prog.NewContinuousVariables(1, "m_friction")[0]
        prog.AddBoundingBoxConstraint(0.0, mu, m)
        n = 2 * (K + 1)
        for i, seg in enumerate(program.segs):
            variables = np.concatenate([program.S[i][:, :2].reshape(-1), [program.foot[i], m]])
            binding = prog.AddConstraint(dual_constraint(_friction_to_spare(K, seg.height, mu), n), np.zeros(n),
                                         np.full(n, np.inf), variables)
            binding.evaluator().SetGradientSparsityPattern(
                [(r, c) for k in range(K + 1) for r in (k, K + 1 + k)
                 for c in (2 * k, 2 * k + 1, 2 * (K + 1), 2 * (K + 1) + 1)])
            program.groups.setdefault("friction_margin", []).append(binding)
        prog.AddLinearCost(-w.friction / FRICTION_SCALE * m)
    return margins


def _stroke_left(K: int, h: float):
    """Leg length - m_s at the interior knots, over their (x, z), the foot and m_s (lower bound: min_leg_length)."""
    lengths = interior_leg_lengths(K, h)
    return lambda v: lengths(v[:-1]) - v[-1]


def _friction_to_spare(K: int, h: float, mu: float):
    """(mu - m_f)(z - h) - (x - f) at every knot, then (mu - m_f)(z - h) + (x - f) (all >= 0), over the knots'
    (x, z), the foot and m_f."""
    def rows(v):
        x, z, f, m = v[0:2 * (K + 1):2], v[1:2 * (K + 1):2], v[2 * (K + 1)], v[2 * (K + 1) + 1]
        reach, lean = (mu - m) * (z - h), x - f
        return Dual.concat([reach - lean, reach + lean])
    return rows


def knot_margins(program, x: np.ndarray) -> dict:
    """The plan's margins at the decision vector x, the least over the knots of every hop: ``stroke`` (spring
    travel left at the interior knots [m]) and ``friction`` (mu - |x - f| / (z - h), at every knot)."""
    p, K = program.params.as_array(), program.K
    value = lambda var: x[program.prog.FindDecisionVariableIndices(np.ravel(var))].reshape(np.shape(var))
    stroke, friction = [], []
    for i, seg in enumerate(program.segs):
        S, f = value(program.S[i]), float(value(program.foot[i]))
        stroke += [dyn.stroke_left(s[0], s[1], f, seg.height, p) for s in S[1:K]]
        friction += [dyn.friction_margin(s[0], s[1], f, seg.height, p) / (s[1] - seg.height) for s in S]
    return {"stroke": min(stroke), "friction": min(friction)}
