"""Training loop for the CNN+LSTM footstep model: plain PyTorch, readable top to bottom.

Previous-step inputs: the first input is the one-hot cell under the body; later inputs are teacher-forced
one-hot footholds, except that for a fraction ``own_inputs`` of the sequences in every batch they are replaced
by the model's own (detached) distributions from a teacher-forced pass. At planning time the model is fed its
own distributions, so training on both keeps it calibrated to soft inputs.
"""
from __future__ import annotations

import hashlib
import json
import math
import os
import time
from dataclasses import asdict

import numpy as np
import torch
import torch.nn.functional as F

from drakeslip.jobs.files import sha256

from planners.learned.inputs import HEIGHT_FLOOR, pad_steps
from planners.learned.config import ModelConfig
from planners.learned.training.config import TrainConfig
from planners.learned.model import FootstepModel, load_checkpoint, save_checkpoint


def load_dataset(folder: str, max_sequences: int = 0) -> tuple[dict, int]:
    """Concatenate the shards in ``folder`` (or several, comma-separated) into arrays: terrain (N, n), apex
    (N, 3), s0 (N,), steps (N, T) with -1 padding, as output bins; ``subcells`` is the bins per cell (1 for
    shards that predate it). A folder written ``FOLDER:ditch`` or ``FOLDER:no-ditch`` keeps only the sequences
    whose window holds a cell at the encoding's floor (a ditch-world ditch; step-world levels never reach it),
    or only those without one: e.g. to replace a dataset's ditch labels by another expert's."""
    parts = []
    for one in folder.split(","):
        one, _, select = one.partition(":")
        if select not in ("", "ditch", "no-ditch"):
            raise ValueError(f"dataset selector {select!r} in {folder!r}: use FOLDER, FOLDER:ditch or FOLDER:no-ditch")
        files = sorted(f for f in os.listdir(one) if f.endswith(".npz"))
        if not files:
            raise ValueError(f"no dataset shards (*.npz) in {one}")
        for f in files:
            shard = dict(np.load(os.path.join(one, f)))
            if select:
                keep = (shard["terrain"] <= HEIGHT_FLOOR).any(axis=1) == (select == "ditch")
                shard.update({k: v[keep] for k, v in shard.items() if k != "subcells"})
            parts.append(shard)
    t_max = max(p["steps"].shape[1] for p in parts)
    steps = np.concatenate([pad_steps(p["steps"], t_max, -1) for p in parts])
    data = {"terrain": np.concatenate([p["terrain"] for p in parts]).astype(np.float32),
            "apex": np.concatenate([p["apex"] for p in parts]).astype(np.float32),
            "s0": np.concatenate([p["s0"] for p in parts]).astype(np.int64),
            "steps": steps.astype(np.int64)}
    if all("viable" in p for p in parts):  # packed bits over the bins, per step
        data["viable"] = np.concatenate([pad_steps(p["viable"], t_max) for p in parts])
    subcells = {int(p["subcells"]) if "subcells" in p else 1 for p in parts}
    if len(subcells) != 1:
        raise ValueError(f"dataset in {folder} mixes shards with different bins per cell: {sorted(subcells)}")
    n_bins = data["terrain"].shape[1] * (subcells := subcells.pop())
    if data["steps"].max() >= n_bins or data["s0"].max() >= n_bins or data["s0"].min() < 0:
        raise ValueError(f"dataset in {folder} has foothold bins outside the {n_bins}-bin window")
    if max_sequences:
        data = {k: v[:max_sequences] for k, v in data.items()}
    return data, subcells


def one_hot_inputs(s0: torch.Tensor, steps: torch.Tensor, n_bins: int) -> torch.Tensor:
    """Teacher-forced previous steps: [s0, step_1, ..., step_{T-1}] as one-hot (padding -> zeros)."""
    prev_idx = torch.cat((s0.unsqueeze(1), steps[:, :-1]), dim=1)
    return F.one_hot(prev_idx.clamp(min=0), n_bins).float() * (prev_idx >= 0).unsqueeze(-1)


def soft_targets(steps: torch.Tensor, viable: torch.Tensor, n_bins: int, weight: float) -> torch.Tensor:
    """(1 - weight) on each step's label and ``weight`` spread evenly over its viable set (unpacked bits;
    the label is always one of them); padded steps get all zeros."""
    bits = torch.arange(7, -1, -1, device=viable.device)
    sets = ((viable.unsqueeze(-1).long() >> bits) & 1).flatten(-2)[..., :n_bins].float()
    onehot = F.one_hot(steps.clamp(min=0), n_bins).float()
    sets = torch.maximum(sets, onehot)
    q = (1 - weight) * onehot + weight * sets / sets.sum(-1, keepdim=True)
    return q * (steps >= 0).unsqueeze(-1)


def batch_loss(model: FootstepModel, batch: dict, own_inputs: float = 0.0, generator=None,
               viable_weight: float = 0.0):
    """Cross-entropy over the real (non-padded) steps, against the labels or, with ``viable_weight`` > 0, the
    soft targets; returns (loss, top-1 hits, within-one-cell hits, count)."""
    n, k = model.config.n_bins, model.config.subcells
    prev = one_hot_inputs(batch["s0"], batch["steps"], n)
    if own_inputs > 0:
        with torch.no_grad():
            own = torch.softmax(model(batch["terrain"], batch["apex"], prev)[0], dim=-1)
        use_own = torch.rand(prev.shape[0], device=prev.device, generator=generator) < own_inputs
        # Step i's input is the model's distribution for step i-1; the first input stays the one-hot s0.
        soft = torch.cat((prev[:, :1], own[:, :-1] * (batch["steps"][:, :-1] >= 0).unsqueeze(-1)), dim=1)
        prev = torch.where(use_own.view(-1, 1, 1), soft, prev)
    logits, _ = model(batch["terrain"], batch["apex"], prev)
    target = batch["steps"]
    valid = target >= 0
    if viable_weight > 0:
        q = soft_targets(target, batch["viable"][:, :target.shape[1]], n, viable_weight)
        loss = -(q * torch.log_softmax(logits, -1)).sum() / valid.sum().clamp(min=1)
    else:
        loss = F.cross_entropy(logits.reshape(-1, n), target.reshape(-1), ignore_index=-1)
    pred = logits.argmax(-1)
    top1 = ((pred == target) & valid).sum().item()
    near = (((pred - target).abs() <= k) & valid).sum().item()
    return loss, top1, near, valid.sum().item()


def _batches(data: dict, idx: np.ndarray, batch_size: int, device: str):
    for start in range(0, idx.size, batch_size):
        sel = idx[start:start + batch_size]
        batch = {k: v[sel] for k, v in data.items()}
        batch["steps"] = batch["steps"][:, :max(int((batch["steps"] >= 0).sum(axis=1).max()), 1)]  # drop padding
        yield {k: torch.from_numpy(v).to(device) for k, v in batch.items()}


def evaluate(model: FootstepModel, data: dict, idx: np.ndarray, cfg: TrainConfig) -> dict:
    model.eval()
    total = top1 = near = count = 0.0
    with torch.no_grad():
        for batch in _batches(data, idx, cfg.batch_size, cfg.device):
            loss, t1, nr, c = batch_loss(model, batch, viable_weight=cfg.viable_weight)
            total += loss.item() * c
            top1, near, count = top1 + t1, near + nr, count + c
    model.train()
    return {"loss": total / max(count, 1), "top1": top1 / max(count, 1), "within1": near / max(count, 1)}


def training_setup(cfg: TrainConfig, model_config: ModelConfig) -> str:
    """A digest of what a training run's result depends on besides its length and device: the dataset's shards
    (their bytes, and any ditch selector), the model's configuration, the weights it starts from and every other
    training setting. A checkpoint resumes only the run that wrote it."""
    digest = hashlib.sha256()
    for one in cfg.data.split(","):
        folder, _, select = one.partition(":")
        digest.update(select.encode())
        for name in sorted(f for f in os.listdir(folder) if f.endswith(".npz")):
            digest.update(name.encode() + sha256(os.path.join(folder, name)).encode())
    settings = {k: v for k, v in asdict(cfg).items() if k not in ("data", "epochs", "device", "checkpoint", "out")}
    settings["init"] = sha256(cfg.init) if cfg.init else ""
    digest.update(json.dumps([settings, asdict(model_config)], sort_keys=True, default=str).encode())
    return digest.hexdigest()


def train(cfg: TrainConfig, model_config: ModelConfig | None = None, log=print,
          width: tuple = (ModelConfig.hidden, ModelConfig.channels)) -> dict:
    """Train (or resume from ``cfg.checkpoint``) and write the final weights to ``cfg.out``. The model's bins
    per cell come from the dataset and its (LSTM units, CNN channels) from ``width`` unless ``model_config``
    is given, or from ``cfg.init``'s weights, which training then starts from."""
    torch.manual_seed(cfg.seed)
    rng = np.random.default_rng(cfg.seed)
    data, subcells = load_dataset(cfg.data, cfg.max_sequences)
    if cfg.viable_weight > 0 and "viable" not in data:
        raise ValueError(f"viable_weight={cfg.viable_weight} needs viable sets, which the shards in {cfg.data} "
                         "predate; regenerate them")
    model = initial_model(cfg, model_config or ModelConfig(subcells=subcells, hidden=width[0], channels=width[1]))
    model_config = model.config
    n = data["terrain"].shape[0]
    if data["terrain"].shape[1] != model_config.n_cells or subcells != model_config.subcells:
        raise ValueError(f"dataset windows have {data['terrain'].shape[1]} cells of {subcells} bins, model expects "
                         f"{model_config.n_cells} of {model_config.subcells}")
    order = rng.permutation(n)
    n_val = max(1, int(round(cfg.val_fraction * n)))
    val_idx, train_idx = order[:n_val], order[n_val:]

    opt = torch.optim.AdamW(model.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)
    history, start_epoch, best = [], 0, math.inf
    setup = training_setup(cfg, model_config)
    if cfg.checkpoint and os.path.exists(cfg.checkpoint):
        model, payload = load_checkpoint(cfg.checkpoint)
        if payload.get("setup") != setup:
            raise ValueError(f"checkpoint {cfg.checkpoint} was written by another training setup (dataset, model or "
                             "settings other than --epochs and --device); remove it or give another --checkpoint")
        model = model.to(cfg.device).train()   # the optimizer's state follows its parameters' device
        opt = torch.optim.AdamW(model.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)
        opt.load_state_dict(payload["optimizer"])
        history, start_epoch, best = payload["history"], payload["epoch"] + 1, payload["best_val"]
        log(f"resumed from {cfg.checkpoint} at epoch {start_epoch}")
    generator = torch.Generator(device=cfg.device).manual_seed(cfg.seed)

    for epoch in range(start_epoch, cfg.epochs):
        t0 = time.time()
        train_loss = train_epoch(model, opt, data, train_idx, epoch, cfg, generator)
        val = evaluate(model, data, val_idx, cfg)
        row = {"epoch": epoch, "train_loss": train_loss, **{f"val_{k}": v for k, v in val.items()},
               "seconds": time.time() - t0}
        history.append(row)
        log(json.dumps({k: round(v, 4) if isinstance(v, float) else v for k, v in row.items()}))
        if val["loss"] < best:
            best = val["loss"]
            save_checkpoint(cfg.out, model, {"train_config": asdict(cfg), "val": val})
        if cfg.checkpoint:
            save_checkpoint(cfg.checkpoint, model, {"optimizer": opt.state_dict(), "epoch": epoch,
                                                    "history": history, "best_val": best, "setup": setup})
    return {"history": history, "best_val_loss": best, "n_train": int(train_idx.size), "n_val": int(n_val)}


def initial_model(cfg: TrainConfig, model_config: ModelConfig) -> FootstepModel:
    """The model training starts from, on ``cfg.device``: ``cfg.init``'s weights, else a new ``model_config`` one."""
    if cfg.init:
        return load_checkpoint(cfg.init)[0].to(cfg.device).train()
    return FootstepModel(model_config).to(cfg.device)


def train_epoch(model, opt, data, train_idx, epoch: int, cfg: TrainConfig, generator) -> float:
    """One epoch over the training sequences (in an order drawn from the seed and the epoch), with the cosine
    schedule's learning rate; the mean training loss."""
    for group in opt.param_groups:  # cosine schedule, recomputed so that resuming needs no scheduler state
        group["lr"] = 0.5 * cfg.lr * (1 + math.cos(math.pi * epoch / cfg.epochs))
    epoch_idx = train_idx[np.random.default_rng(cfg.seed + epoch).permutation(train_idx.size)]
    total = count = 0.0
    for batch in _batches(data, epoch_idx, cfg.batch_size, cfg.device):
        loss, _, _, c = batch_loss(model, batch, cfg.own_inputs, generator, cfg.viable_weight)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        torch.nn.utils.clip_grad_norm_(model.parameters(), 1.0)
        opt.step()
        total, count = total + loss.item() * c, count + c
    return total / max(count, 1)
