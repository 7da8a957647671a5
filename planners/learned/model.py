"""The paper's CNN+LSTM footstep model (section VI).

    h0    = g0(a)                     a single linear layer from the initial apex to the LSTM state
    v_i   = CNN([t, s_{i-1}])         terrain window and previous-step distribution, two channels of a 1-D image
    s_i, h_i = LSTM(h_{i-1}, v_i)     2 layers x 110 units; a linear head gives logits over the window's cells

Inputs, all in the perception window of ``n_cells`` cells (8 m ahead, 3 m behind the body, 10 cm cells):
``terrain`` (B, n_cells) heights relative to the ground under the body, clipped to [-1, 1]; ``apex`` (B, 3) =
(body height above the ground under it, forward speed, body x offset inside its cell); ``prev`` (B, T,
n_cells) the previous step of each of the T steps as a distribution over cells. ``s_0`` is the one-hot cell
under the body at the start apex (our planner is called at the apex, before the leg angle is chosen, so the
body's own cell replaces the paper's "inevitable touchdown").

``subcells`` > 1 splits every cell into that many output bins (2.5 cm for 4): the head gives
logits over n_cells * subcells bins and the previous step enters the CNN as ``subcells`` channels (bin k of
each cell in channel k), so the image keeps the terrain's 10 cm resolution. ``subcells=1`` is the paper's model.
"""
from __future__ import annotations

import torch
from torch import nn

from planners.learned.checkpoint import load_model_checkpoint, save_model_checkpoint
from planners.learned.config import ModelConfig

FORMAT = "drakeslip-lstm/1"


class FootstepModel(nn.Module):
    def __init__(self, config: ModelConfig = ModelConfig()):
        super().__init__()
        c = config
        self.config = c
        self.g0 = nn.Linear(c.apex_features, 2 * c.layers * c.hidden)  # initial (h, c) of every layer
        self.cnn = nn.Sequential(
            nn.Conv1d(1 + c.subcells, c.channels, c.kernel, padding=c.kernel // 2), nn.ReLU(),
            nn.Conv1d(c.channels, c.channels, c.kernel, padding=c.kernel // 2), nn.ReLU(),
            nn.Flatten(), nn.Linear(c.channels * c.n_cells, c.n_cells), nn.ReLU())
        self.lstm = nn.LSTM(c.n_cells, c.hidden, num_layers=c.layers, batch_first=True)
        self.head = nn.Linear(c.hidden, c.n_bins)

    def initial_state(self, apex: torch.Tensor):
        c = self.config
        hc = self.g0(apex).view(-1, 2, c.layers, c.hidden).permute(1, 2, 0, 3)
        return hc[0].contiguous(), hc[1].contiguous()

    def encode(self, terrain: torch.Tensor, prev: torch.Tensor) -> torch.Tensor:
        """Terrain (B, n) and previous steps (B, T, n * subcells) -> (B, T, n) LSTM inputs."""
        b, t, n, k = prev.shape[0], prev.shape[1], terrain.shape[-1], self.config.subcells
        steps = prev.reshape(b, t, n, k).transpose(2, 3)  # (B, T, subcells, n)
        image = torch.cat((terrain.view(b, 1, 1, n).expand(b, t, 1, n), steps), dim=2)
        return self.cnn(image.reshape(b * t, 1 + k, n)).view(b, t, -1)

    def forward(self, terrain, apex, prev, state=None):
        """Logits (B, T, n_bins) for steps 1..T given the previous steps; returns (logits, lstm state)."""
        out, state = self.lstm(self.encode(terrain, prev), state if state is not None else self.initial_state(apex))
        return self.head(out), state

    @torch.no_grad()
    def rollout(self, terrain, apex, s0, n_steps: int, mask=None, temperature: float = 1.0):
        """Plan n_steps ahead, feeding each step's own distribution back in (the paper's planning mode).
        ``mask`` (B, n_bins) bool marks bins a foot may never use (e.g. ditches). Returns (B, n_steps, n_bins)."""
        prev = s0.unsqueeze(1)
        state = self.initial_state(apex)
        probs = []
        for _ in range(n_steps):
            logits, state = self.forward(terrain, apex, prev, state)
            logits = logits[:, -1] / temperature
            if mask is not None:
                logits = logits.masked_fill(mask, float("-inf"))
            p = torch.softmax(logits, dim=-1)
            probs.append(p)
            prev = p.unsqueeze(1)
        return torch.stack(probs, dim=1)


def save_checkpoint(path, model: FootstepModel, extra: dict | None = None) -> None:
    """Write weights and config atomically (``planners.learned.checkpoint``)."""
    save_model_checkpoint(path, model, FORMAT, extra)


def load_checkpoint(path) -> tuple[FootstepModel, dict]:
    """Load a checkpoint written by save_checkpoint, checked against its folder's SHA-256 manifest; a changed,
    corrupt or mismatched file raises ValueError naming it."""
    return load_model_checkpoint(path, FORMAT, FootstepModel, ModelConfig, "LSTM")
