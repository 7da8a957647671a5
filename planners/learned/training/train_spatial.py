"""Training loop for the spatial footstep model: plain PyTorch, readable top to bottom. Cross-entropy of the model's
distribution over the patch's cells against each sample's soft label (planners/learned/training/spatial_dataset.py);
every 20th sample is held out, and the held-out loss and top-k hit rates are reported."""
from __future__ import annotations

import os
import numpy as np
import torch

from planners.learned.config import SpatialModelConfig
from planners.learned.spatial_model import SpatialFootstepModel, save_spatial_checkpoint
from planners.learned.training.config import SpatialTrainConfig

HELD_OUT_EVERY = 20


def load_spatial_dataset(folder: str) -> dict:
    """Every shard of ``folder`` (``*.npz``, in name order) concatenated; ValueError when there is none."""
    files = sorted(f for f in os.listdir(folder) if f.endswith(".npz"))
    if not files:
        raise ValueError(f"no dataset shards (*.npz) in {folder}")
    parts = [np.load(os.path.join(folder, f)) for f in files]
    return {k: np.concatenate([p[k] for p in parts]) for k in ("patch", "features", "past", "label")}


def batch_loss(model, batch) -> torch.Tensor:
    logits = model(batch["patch"], batch["features"], batch["past"])
    return -(batch["label"] * torch.log_softmax(logits, dim=1)).sum(dim=1).mean()


def tensors(data: dict, idx: np.ndarray, device: str) -> dict:
    return {k: torch.as_tensor(v[idx], dtype=torch.float32, device=device) for k, v in data.items()}


@torch.no_grad()
def held_out_report(model, data: dict, idx: np.ndarray, device: str) -> dict:
    """The held-out loss, and how often the label's most likely cell is among the model's top 1, 4 and 8 cells."""
    batch = tensors(data, idx, device)
    logits = model(batch["patch"], batch["features"], batch["past"])
    best = batch["label"].argmax(dim=1, keepdim=True)
    order = logits.argsort(dim=1, descending=True)
    hits = {f"top{k}": float((order[:, :k] == best).any(dim=1).float().mean()) for k in (1, 4, 8)}
    return {"loss": float(batch_loss(model, batch)), **hits}


def train_spatial(cfg: SpatialTrainConfig, model_config: SpatialModelConfig = SpatialModelConfig(),
                  log=print) -> dict:
    """Train from scratch on ``cfg.data`` and write the weights to ``cfg.out``; returns the held-out report."""
    torch.manual_seed(cfg.seed)
    generator = np.random.default_rng(cfg.seed)
    data = load_spatial_dataset(cfg.data)
    n = data["label"].shape[0]
    held = np.arange(0, n, HELD_OUT_EVERY)
    train_idx = np.setdiff1d(np.arange(n), held)
    model = SpatialFootstepModel(model_config).to(cfg.device)
    opt = torch.optim.Adam(model.parameters(), lr=cfg.lr)
    schedule = torch.optim.lr_scheduler.CosineAnnealingLR(opt, cfg.epochs)
    log(f"{n} samples: {train_idx.size} to train on, {held.size} held out")
    for epoch in range(cfg.epochs):
        model.train()
        order = generator.permutation(train_idx)
        total = 0.0
        for start in range(0, order.size, cfg.batch_size):
            loss = batch_loss(model, tensors(data, order[start:start + cfg.batch_size], cfg.device))
            opt.zero_grad()
            loss.backward()
            opt.step()
            total += loss.item() * min(cfg.batch_size, order.size - start)
        schedule.step()
        model.eval()
        report = held_out_report(model, data, held, cfg.device)
        log(f"epoch {epoch + 1}/{cfg.epochs}: train {total / order.size:.4f}, held out {report['loss']:.4f}, "
            f"top-1 {report['top1']:.3f}, top-4 {report['top4']:.3f}, top-8 {report['top8']:.3f}")
    save_spatial_checkpoint(cfg.out, model.cpu(), {"held_out": report, "samples": int(n)})
    return report
