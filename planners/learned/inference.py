"""The footstep model's forward pass in numpy, for planning.

A planner runs the model one step at a time on one window (batch 1). At that size torch's per-call overhead
and thread pool dominate (about 1 ms per step on an idle core, far more when the cores are shared), while
the same arithmetic in numpy takes tens of microseconds. Training stays in torch (planners/learned/model.py); this holds
a copy of the trained weights and computes the same function (tests/test_lstm.py checks the two agree).
"""
from __future__ import annotations

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from planners.learned.model import FootstepModel


def _sigmoid(x):
    return 0.5 * (1.0 + np.tanh(0.5 * x))


class NumpyFootstepModel:
    """``initial_state(apex)``, ``step(terrain, prev, state) -> (logits, state)`` and ``rollout`` with the
    same meaning as FootstepModel's, on numpy arrays (float64), batch first."""

    def __init__(self, model: FootstepModel):
        w = {k: v.detach().double().cpu().numpy() for k, v in model.state_dict().items()}
        self.config = c = model.config
        self.g0 = (w["g0.weight"], w["g0.bias"])
        # a 1-D convolution as one matrix product over the (input channel, tap) windows of every cell
        self.conv = [(w[f"cnn.{i}.weight"].reshape(c.channels, -1).T, w[f"cnn.{i}.bias"]) for i in (0, 2)]
        self.fc = (w["cnn.5.weight"], w["cnn.5.bias"])
        self.lstm = [(w[f"lstm.weight_ih_l{k}"], w[f"lstm.weight_hh_l{k}"], w[f"lstm.bias_ih_l{k}"] + w[f"lstm.bias_hh_l{k}"])
                     for k in range(c.layers)]
        self.head = (w["head.weight"], w["head.bias"])

    def initial_state(self, apex: np.ndarray):
        c = self.config
        hc = (np.atleast_2d(apex) @ self.g0[0].T + self.g0[1]).reshape(-1, 2, c.layers, c.hidden)
        return hc[:, 0].transpose(1, 0, 2).copy(), hc[:, 1].transpose(1, 0, 2).copy()  # (layers, B, hidden)

    def _encode(self, terrain: np.ndarray, prev: np.ndarray) -> np.ndarray:
        b, n = terrain.shape
        x = np.concatenate((terrain[:, None], prev.reshape(b, n, -1).transpose(0, 2, 1)), axis=1)  # (B, C, n)
        k = self.config.kernel
        for weight, bias in self.conv:
            windows = sliding_window_view(np.pad(x, ((0, 0), (0, 0), (k // 2, k // 2))), k, axis=2)  # (B, C, n, k)
            x = np.maximum(windows.transpose(0, 2, 1, 3).reshape(b, n, -1) @ weight + bias, 0.0).transpose(0, 2, 1)
        return np.maximum(x.reshape(b, -1) @ self.fc[0].T + self.fc[1], 0.0)

    def step(self, terrain: np.ndarray, prev: np.ndarray, state):
        """One step for a batch: terrain (B, n), prev (B, n_bins) -> logits (B, n_bins), the state after it."""
        x = self._encode(terrain, prev)
        h, c = state
        h, c = h.copy(), c.copy()
        for k, (w_ih, w_hh, b) in enumerate(self.lstm):
            i, f, g, o = np.split(x @ w_ih.T + h[k] @ w_hh.T + b, 4, axis=1)  # torch's gate order
            c[k] = _sigmoid(f) * c[k] + _sigmoid(i) * np.tanh(g)
            h[k] = x = _sigmoid(o) * np.tanh(c[k])
        return x @ self.head[0].T + self.head[1], (h, c)

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
    """Softmax over the last axis; ``mask`` True cells get probability 0."""
    if mask is not None:
        logits = np.where(mask, -np.inf, logits)
    z = np.exp(logits - logits.max(axis=-1, keepdims=True))
    return z / z.sum(axis=-1, keepdims=True)
