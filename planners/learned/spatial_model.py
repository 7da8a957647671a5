"""The spatial footstep model: a CNN over the height-map patch ahead of the hopper and an LSTM over its past
footholds, giving a distribution over the patch's cells for the next foothold.

    z1 = relu(conv3x3([patch, coords])) the patch: heights below the apex and holes, and each cell's place in it
    z2 = conv3x3(z1)
    h  = LSTM(past footholds)           the last few footholds of the branch, in the heading frame
    logits = head(relu(z2 + W [apex features, h]))    a 1x1 head, conditioned per channel

Its inputs are made by ``planners.core.spatial_model.node_view`` and its compiled forward pass for planning is
``planners.core.spatial_model.logits_of`` (tests check the two agree); ``arrays`` gives that pass its weights."""
from __future__ import annotations

import numpy as np
import torch
from torch import nn

from planners.core.spatial_model import N_APEX, N_COORDS, N_HISTORY, SpatialModelArrays, patch_coordinates
from planners.learned.checkpoint import load_model_checkpoint, save_model_checkpoint
from planners.learned.config import SpatialModelConfig

FORMAT = "drakeslip-spatial-footstep/1"


class SpatialFootstepModel(nn.Module):
    def __init__(self, config: SpatialModelConfig = SpatialModelConfig()):
        super().__init__()
        c = self.config = config
        self.conv1 = nn.Conv2d(2 + N_COORDS, c.channels, 3, padding=1)
        self.register_buffer("coords", torch.as_tensor(patch_coordinates(c.size)), persistent=False)
        self.conv2 = nn.Conv2d(c.channels, c.channels, 3, padding=1)
        self.lstm = nn.LSTM(N_HISTORY, c.hidden, batch_first=True)
        self.cond = nn.Linear(N_APEX + c.hidden, c.channels)
        self.head = nn.Conv2d(c.channels, 1, 1)

    def forward(self, patch, features, past):
        """Logits (B, size * size) for patches (B, 2, size, size), apex features (B, N_APEX), history (B, K, 3)."""
        image = torch.cat([patch, self.coords.to(patch.dtype).expand(patch.shape[0], -1, -1, -1)], dim=1)
        z2 = self.conv2(torch.relu(self.conv1(image)))
        _, (h, _) = self.lstm(past)
        bias = self.cond(torch.cat([features, h[-1]], dim=1))
        return self.head(torch.relu(z2 + bias[:, :, None, None])).flatten(1)

    def arrays(self) -> SpatialModelArrays:
        """The weights as the compiled forward pass reads them (float64)."""
        def a(t):
            return np.ascontiguousarray(t.detach().cpu().double().numpy())

        return SpatialModelArrays(a(self.conv1.weight), a(self.conv1.bias), a(self.conv2.weight), a(self.conv2.bias),
                                  a(self.lstm.weight_ih_l0), a(self.lstm.weight_hh_l0),
                                  a(self.lstm.bias_ih_l0 + self.lstm.bias_hh_l0), a(self.cond.weight),
                                  a(self.cond.bias), a(self.head.weight.reshape(-1)), a(self.head.bias))


def save_spatial_checkpoint(path, model: SpatialFootstepModel, extra: dict | None = None) -> None:
    """Write the weights and config atomically, and their digest in the folder's manifest."""
    save_model_checkpoint(path, model, FORMAT, extra)


def load_spatial_checkpoint(path) -> tuple[SpatialFootstepModel, dict]:
    """A checkpoint written by ``save_spatial_checkpoint``, checked against its folder's SHA-256 manifest; a changed,
    corrupt or mismatched file raises ValueError naming it."""
    return load_model_checkpoint(path, FORMAT, SpatialFootstepModel, SpatialModelConfig, "spatial footstep")
