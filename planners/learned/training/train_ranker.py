"""Data and training for the foothold ranker (planners/learned/ranker.py): plain PyTorch, readable top to bottom.

Data are DAgger rounds. In each round the one-step mode planner runs the receding-horizon protocol (fast
backend) from the cases of freshly drawn terrains; at every state it records its ``record_k`` most probable
usable first footholds, their features and their room a hop later (the label), then hops to the learner's pick:
the mode in round 0, the previous round's ranker after that, or, with probability ``explore``, the candidate of
most room (the expert), so that a rollout goes on past the learner's mistakes and the data hold the states the
learner gets itself into. Training scores every candidate of a state and minimises the cross-entropy between the
softmax over a state's candidates and the uniform distribution over its candidates of most room.

A round's shards are tasks of the job runner (``drakeslip.jobs``): ``collect_shard`` runs wherever the executor
puts it, gets the weights it needs as bytes and returns the shard's arrays, and the driver writes each as it
arrives (``shard_store``), so the workers share no filesystem with it (examples/train_ranker.py runs the rounds).
"""
from __future__ import annotations

import time

import numpy as np
import torch

from drakeslip import SlipParams
from drakeslip.hopper_file import NamedHopper
from drakeslip.jobs.files import atomic_write
from drakeslip.jobs.runner import FileStore

from planners.closed_loop import ClosedLoopConfig, run_case
from planners.formats.suite import make_suite
from planners.formats.suite_draw import draw_suite
from planners.learned.lstm import LSTMPlanner
from planners.learned.ranker import N_FEATURES, RankerNet, candidate_features, log_probability, top_candidates
from planners.learned.training.config import RankerTrainConfig
from planners.learned.training.dataset import local_copy
from planners.learned.training.labels import OneHopRoom

__all__ = ["CollectingPlanner", "collect", "collect_shard", "save_shard", "shard_store", "RankerTrainConfig",
           "train"]


class CollectingPlanner(LSTMPlanner):
    """The one-step mode planner that records its states (see the module doc); ``ranker`` is the learner."""

    def __init__(self, record_k: int, explore: float, seed: int, **options):
        super().__init__(max_steps=1, **options)
        self.record_k, self.explore = record_k, explore
        self.rng = np.random.default_rng(seed)
        self.label = OneHopRoom(self.controller)
        self.features, self.rooms = [], []

    def pick_first(self, problem, grid, score, theta):
        top = top_candidates(score, self.record_k)
        if top.size < 2:
            return score
        x, theta = grid[top], theta[top]
        features = candidate_features(problem, x, log_probability(score, top), theta)
        room = self.label(problem, x, theta)
        self.features.append(np.pad(features, ((0, self.record_k - top.size), (0, 0))))
        self.rooms.append(np.pad(room, (0, self.record_k - top.size), constant_values=np.nan))
        if self.rng.random() < self.explore:
            pick = int(np.argmax(room))
        elif self.ranker is not None:
            pick = int(np.argmax(self.ranker.scores(features[:self.top_k])))
        else:
            pick = 0
        return np.where(np.arange(score.size) == top[pick], score, 0.0)


# many parameters: a job runner task's arguments, sent to a worker as they are
def collect(family: str, seed: int, n_terrains: int, model, ranker, record_k: int, top_k: int, explore: float,
            hopper: dict | None = None):
    """One shard: (features (states, record_k, N_FEATURES), rooms (states, record_k), NaN where a state had fewer
    candidates) from every case of ``n_terrains`` terrains of ``family`` from terrain seed ``seed``, the planner
    running the footstep model ``model`` (a checkpoint file) with the learner ``ranker``, for the hopper whose
    SlipParams fields are ``hopper`` on a suite drawn for it (None: the paper's hopper on the paper's suite)."""
    if hopper is None:
        suite = make_suite(family, seed, n_terrains)
        params = SlipParams(friction=suite.friction)
    else:
        suite = draw_suite(family, seed, NamedHopper(SlipParams(**hopper), "training"), n_terrains)
        params = SlipParams(**hopper).with_friction(suite.friction)
    planner = CollectingPlanner(record_k, explore, seed, model=model, ranker=ranker, top_k=top_k)
    for case in suite.cases:
        run_case(planner, planner.controller, case, suite.goal_x, params, ClosedLoopConfig(backend="fast"))
    if not planner.features:
        return np.zeros((0, record_k, N_FEATURES), np.float32), np.zeros((0, record_k))
    return np.stack(planner.features), np.stack(planner.rooms)


# many parameters: a job runner task's arguments, sent to a worker as they are
def collect_shard(family: str, seed: int, n_terrains: int, model: bytes, ranker: bytes | None, record_k: int,
                  top_k: int, explore: float, hopper: dict | None = None):
    """``collect`` as a task of the job runner: the footstep ``model`` and the learner's ``ranker``
    (None: follow the mode) come as the contents of their files, so a worker needs no filesystem shared with the
    driver; returns the shard's (features, rooms) for the driver to write (``save_shard``)."""
    return collect(family, seed, n_terrains, local_copy(model, ".pt"),
                   None if ranker is None else local_copy(ranker, ".pt"), record_k, top_k, explore, hopper)


def save_shard(path, shard) -> None:
    """Write a shard's (features, rooms) as one .npz, atomically (the driver's side)."""
    features, rooms = shard
    with atomic_write(path) as f:
        np.savez(f, features=features, rooms=rooms)


def shard_store(folder) -> FileStore:
    """A data folder's shards as a store of the job runner, keyed by their file names."""
    return FileStore(folder, str, save_shard)


def train(features: np.ndarray, rooms: np.ndarray, cfg: RankerTrainConfig, log=print):
    """(net on the CPU, feature mean, feature std, summary) from recorded states, trained on ``cfg.device``; the
    weights kept are those of the epoch with the lowest validation loss. Accuracy: how often the top-scored
    candidate has the most room (the mode's, always taking the first candidate, is printed beside it). The split
    and the batches are drawn on the CPU from ``cfg.seed``, so they are the same on every device."""
    if cfg.threads:
        torch.set_num_threads(cfg.threads)
    torch.manual_seed(cfg.seed)
    rng = np.random.default_rng(cfg.seed)
    valid = ~np.isnan(rooms)
    mean, std = features[valid].mean(0), features[valid].std(0) + 1e-6
    x = torch.tensor(np.where(valid[..., None], (features - mean) / std, 0.0), dtype=torch.float32, device=cfg.device)
    room = np.where(valid, rooms, -np.inf)
    best = torch.tensor((room == room.max(1, keepdims=True)) & valid, device=cfg.device)
    valid = torch.tensor(valid, device=cfg.device)
    order = rng.permutation(len(x))
    n_val = max(1, int(cfg.val_fraction * len(x)))
    val, tr = torch.tensor(order[:n_val], device=cfg.device), order[n_val:]
    net = RankerNet(cfg.hidden).to(cfg.device)
    opt = torch.optim.Adam(net.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)

    def loss_and_accuracy(idx):
        s = net(x[idx]).masked_fill(~valid[idx], -1e9)
        target = best[idx] / best[idx].sum(1, keepdim=True)
        loss = -(target * torch.log_softmax(s, 1)).sum(1).mean()
        return loss, best[idx].gather(1, s.argmax(1, keepdim=True)).float().mean().item()

    mode_accuracy = best[val, 0].float().mean().item()
    t0, kept, summary = time.time(), None, {}
    for epoch in range(cfg.epochs):
        net.train()
        rng.shuffle(tr)
        for b in range(0, len(tr), cfg.batch_size):
            loss, _ = loss_and_accuracy(torch.tensor(tr[b:b + cfg.batch_size], device=cfg.device))
            opt.zero_grad()
            loss.backward()
            opt.step()
        net.eval()
        with torch.no_grad():
            val_loss, val_accuracy = loss_and_accuracy(val)
        row = {"epoch": epoch, "val_loss": round(val_loss.item(), 4), "val_accuracy": round(val_accuracy, 4),
               "mode_accuracy": round(mode_accuracy, 4), "seconds": round(time.time() - t0, 1)}
        log(row)
        if kept is None or val_loss.item() < summary["best_val_loss"]:
            kept = {k: v.clone() for k, v in net.state_dict().items()}
            summary = {"best_val_loss": val_loss.item(), "best_epoch": epoch, "val_accuracy": val_accuracy,
                       "mode_accuracy": mode_accuracy}
    net.load_state_dict(kept)
    net.cpu().eval()
    summary.update(states=len(x), train_seconds=round(time.time() - t0, 1))
    return net, mean, std, summary

