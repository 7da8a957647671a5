"""The footstep model as the planners run it: the compiled forward pass of planners/core/model.py behind the torch
model's interface (batch first, one window a row).

A planner runs the model one step at a time on one window. At that size torch's per-call overhead and thread pool
dominate (about 1 ms per step on an idle core, far more when the cores are shared), while the compiled step takes
tens of microseconds. Training stays in torch (planners/learned/model.py); this holds a copy of the trained weights
and computes the same function (tests/test_lstm.py checks the two agree).
"""
from __future__ import annotations

import numpy as np

from planners.core.model import initial_state, masked_softmax, model_arrays, model_step
from planners.learned.model import FootstepModel


class PlanningFootstepModel:
    """``initial_state(apex)``, ``step(terrain, prev, state) -> (logits, state)`` and ``rollout`` with the same
    meaning as FootstepModel's, on float64 numpy arrays, batch first; ``arrays`` the weights as compiled code reads
    them (``planners.core.model.ModelArrays``)."""

    def __init__(self, model: FootstepModel):
        self.config = model.config
        self.arrays = model_arrays(model)

    def initial_state(self, apex: np.ndarray):
        """(h, c) for each apex row, each (layers, B, hidden)."""
        rows = [initial_state(np.ascontiguousarray(a, dtype=np.float64), self.arrays) for a in np.atleast_2d(apex)]
        return np.stack([h for h, _ in rows], axis=1), np.stack([c for _, c in rows], axis=1)

    def step(self, terrain: np.ndarray, prev: np.ndarray, state):
        """One step for a batch: terrain (B, n), prev (B, n_bins) -> logits (B, n_bins), the state after it."""
        h, c = state
        out = [model_step(np.ascontiguousarray(terrain[b], dtype=np.float64),
                          np.ascontiguousarray(prev[b], dtype=np.float64), np.ascontiguousarray(h[:, b]),
                          np.ascontiguousarray(c[:, b]), self.arrays) for b in range(terrain.shape[0])]
        return (np.stack([logits for logits, _, _ in out]),
                (np.stack([h for _, h, _ in out], axis=1), np.stack([c for _, _, c in out], axis=1)))

    def rollout(self, terrain, apex, s0, n_steps: int, mask=None, temperature: float = 1.0) -> np.ndarray:
        """FootstepModel.rollout: each step's distribution fed back as the next input; (B, n_steps, n_bins)."""
        prev, state = s0, self.initial_state(apex)
        probs = []
        for _ in range(n_steps):
            logits, state = self.step(terrain, prev, state)
            prev = softmax(logits / temperature, mask)
            probs.append(prev)
        return np.stack(probs, axis=1)


def softmax(logits: np.ndarray, mask: np.ndarray | None = None) -> np.ndarray:
    """Softmax over the last axis, a row at a time (``planners.core.model.masked_softmax``); ``mask`` True bins get
    probability 0."""
    shape = np.shape(logits)
    rows = np.asarray(logits, dtype=np.float64).reshape(-1, shape[-1])
    masks = np.zeros(rows.shape, dtype=bool) if mask is None else np.broadcast_to(mask, shape).reshape(rows.shape)
    out = [masked_softmax(np.ascontiguousarray(row), 1.0, np.ascontiguousarray(m)) for row, m in zip(rows, masks)]
    return np.stack(out).reshape(shape)
