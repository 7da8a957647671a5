"""Training data for the footstep model: search trees turned into footstep sequences (Table I).

Each instance is one terrain and one initial apex, for the paper's hopper or another (``DatasetConfig.hopper``:
terrains and starts made the hopper's as suites drawn for it are, windows encoded in its units). Its search tree
(Angle-space, as in the paper, or Step-space, see DatasetConfig.planner) is grown to ``goal_sequences`` goals, and
every root-to-leaf path with at least ``min_steps`` footholds that covers at least ``min_progress`` of the distance
to the search target becomes a sequence: the encoded perception window at the initial apex and the window cells
of its footholds. With every step goes its viable set, the cells of all the footholds the search found viable from
the same apex (the step's siblings in the tree), which training can use as soft labels (TrainConfig.viable_weight).
With ``planner="expert"`` the sequences come from rollouts of the goal-reaching expert instead
(``expert_sequences``), whose viable sets are each state's goal-reaching footholds.

Instances are grouped into shards, each a task of the job runner (``drakeslip.jobs``): ``make_shard`` computes a
shard's arrays wherever the executor runs it (this process, local workers, a Ray cluster) and returns them, and
the driver writes each as one .npz atomically as it arrives (``generate``), so an interrupted run resumes by
skipping the shards already on disk. The config (``DatasetConfig``, in config.py so that scripts can parse their
flags without the planners) is recorded in the folder's config.json. The planners, numba and torch are imported
by the functions that use them, so importing this module is light.
"""
from __future__ import annotations

import functools
import hashlib
import json
import os
import tempfile
import time
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np

from drakeslip import ApexState, SlipParams
from drakeslip.jobs.files import atomic_write, read_json
from drakeslip.jobs.runner import FileStore, run
from drakeslip.terrain import check_families
from drakeslip.units import units_of

from planners.learned.inputs import encode_window, pad_steps
from planners.learned.training.config import DatasetConfig

__all__ = ["DatasetConfig", "dataset_hopper", "dataset_goal", "instance", "search_tree", "instance_sequences",
           "expert_sequences", "make_shard", "save_shard", "shard_store", "generate", "statistics", "write_shard",
           "shard_path", "write_manifest", "pending_shards", "count_sequences", "local_copy"]


def dataset_hopper(cfg: DatasetConfig) -> SlipParams:
    """The hopper the data are for (``cfg.hopper``, default the paper's) on ground of the dataset's friction."""
    return (SlipParams() if cfg.hopper is None else SlipParams(**cfg.hopper)).with_friction(cfg.friction)


def dataset_goal(cfg: DatasetConfig) -> float:
    """The goal of every instance [m]: ``cfg.goal_x`` in the hopper's lengths."""
    return cfg.goal_x * units_of(dataset_hopper(cfg)).length


def instance(cfg: DatasetConfig, i: int):
    """Terrain and initial apex of instance i: terrain i // apexes_per_terrain, families alternating. For another
    hopper than the paper's, the paper's terrain and start made the hopper's as a suite drawn for it makes them
    (``planners.formats.suite_draw``: lengths in its lengths, terrain heights, start heights and speeds by its
    physics); for the paper's hopper these are the paper's draws themselves."""
    from planners.formats.suite_draw import hopper_terrain, start_height_factor, suite_scales

    params = dataset_hopper(cfg)
    scales = suite_scales(params)
    t = i // cfg.apexes_per_terrain
    family = cfg.families[t % len(cfg.families)]
    terrain = hopper_terrain(check_families([family])[0], cfg.seed * 1_000_003 + t, scales)
    rng = np.random.default_rng([cfg.seed, i])
    for _ in range(100):  # start over solid ground: near the start or anywhere along the course
        x = rng.uniform(cfg.start_x, 0.5) if rng.random() < 0.25 else rng.uniform(cfg.start_x, cfg.goal_x - 2.0)
        x *= scales.length
        if not terrain.is_ditch_at(x):
            break
    above = rng.uniform(*cfg.height_range)
    above *= scales.length * start_height_factor(params, above)
    apex = ApexState(x, terrain.height_at(x) + above, rng.uniform(*cfg.speed_range) * scales.speed)
    return family, terrain, apex


@functools.cache
def shared_controller():
    """The default step-length controller, loaded once per process: every instance builds its own planner, and
    loading the weights costs more than a Step-space search on the compiled core."""
    from drakeslip.controller import StepLengthController

    return StepLengthController.load_default()


def search_tree(cfg: DatasetConfig, i: int, apex, terrain):
    """The search of instance i, with the dataset's friction; returns (SearchResult, the x its sequences aim to
    pass)."""
    from planners.search.angle_space import AngleSpacePlanner
    from planners.search.step_space import StepSpacePlanner

    params, goal_x = dataset_hopper(cfg), dataset_goal(cfg)
    budget = {"max_nodes": cfg.max_nodes, "max_time_s": cfg.max_time_s}
    if cfg.planner == "angle":
        planner = AngleSpacePlanner(branching=cfg.branching, fallback=(), n_sequences=cfg.goal_sequences,
                                    cost_weights=cfg.cost_weights, seed=cfg.seed * 7919 + i, **budget)
    elif cfg.subcells > 1:
        planner = StepSpacePlanner(controller=shared_controller(), spacing=terrain.cell / cfg.subcells,
                                   fallback_spacing=(), n_sequences=cfg.goal_sequences, cost_weights=cfg.cost_weights,
                                   **budget)
    else:
        planner = StepSpacePlanner(controller=shared_controller(), n_sequences=cfg.goal_sequences,
                                   cost_weights=cfg.cost_weights, **budget)
    return planner.search(apex, terrain, goal_x, params), planner.problem(apex, terrain, goal_x, params, 0.0).target_x


def instance_sequences(cfg: DatasetConfig, i: int) -> dict:
    """All qualifying sequences of instance i as arrays (terrain, apex, s0, steps), plus search statistics;
    s0 and steps are output bins (cells when cfg.subcells is 1)."""
    if cfg.planner == "expert":
        return expert_sequences(cfg, i)
    family, terrain, apex = instance(cfg, i)
    result, target = search_tree(cfg, i, apex, terrain)
    enc = encode_window(terrain, apex, units_of(dataset_hopper(cfg)))
    need = apex.x + cfg.min_progress * (target - apex.x)
    n_bins = enc.terrain.size * cfg.subcells
    tree = result.tree
    siblings: dict = {}  # parent node -> its children's bins: the footholds the search found viable there
    for node in range(1, len(tree)):
        siblings.setdefault(tree.parent[node], []).append(node)
    steps, viable = [], []
    for leaf in tree.leaves():
        nodes = tree.branch(leaf)
        footholds = np.array([tree.foothold[n] for n in nodes])
        if len(nodes) < cfg.min_steps or footholds[-1] < need:
            continue
        bins = enc.bin_of(footholds[:cfg.max_steps], cfg.subcells)
        inside = (bins >= 0) & (bins < n_bins)
        bins = bins[:inside.argmin()] if not inside.all() else bins  # cut at the window's edge
        sets = np.zeros((bins.size, n_bins), dtype=bool)
        for row, node in zip(sets, nodes):
            row[:] = window_bins(enc, [tree.foothold[k] for k in siblings[tree.parent[node]]], cfg.subcells)
        steps.append(bins)
        viable.append(sets)
    if len(steps) > cfg.max_paths_per_instance:
        keep = np.random.default_rng([cfg.seed, i, 1]).choice(len(steps), cfg.max_paths_per_instance, replace=False)
        steps, viable = [steps[k] for k in sorted(keep)], [viable[k] for k in sorted(keep)]
    padded, sets = pack_sequences(steps, viable, n_bins)
    n = len(steps)
    return {"terrain": np.repeat(enc.terrain[None], n, axis=0), "apex": np.repeat(enc.apex[None], n, axis=0),
            "s0": np.full(n, enc.s0_bin(cfg.subcells), dtype=np.int16), "steps": padded, "viable": sets,
            "family": family, "ode_calls": result.ode_calls, "nodes": result.nodes_expanded}


def window_bins(enc, footholds, subcells: int) -> np.ndarray:
    """One bool per output bin of the window, True at the bins of the ``footholds`` that fall inside it."""
    n_bins = enc.terrain.size * subcells
    there = enc.bin_of(footholds, subcells)
    row = np.zeros(n_bins, dtype=bool)
    row[there[(there >= 0) & (there < n_bins)]] = True
    return row


def pack_sequences(steps: list, viable: list, n_bins: int) -> tuple[np.ndarray, np.ndarray]:
    """Sequences of several lengths as arrays: their bins padded with -1, (N, T), and their steps' viable sets
    padded with empty sets, (N, T, n_bins)."""
    t_max = max((s.size for s in steps), default=0)
    padded = np.full((len(steps), t_max), -1, dtype=np.int16)
    sets = np.zeros((len(steps), t_max, n_bins), dtype=bool)
    for row, s, v, out in zip(padded, steps, viable, sets):
        row[:s.size] = s
        out[:s.size] = v
    return padded, sets


def expert_sequences(cfg: DatasetConfig, i: int) -> dict:
    """Instance i's expert rollout as sequences: one from every state it labelled, following the expert's
    choices up to the first hop that went elsewhere (explored, or followed cfg.policy; that step's label is the
    sequence's last). A step's viable set is its state's goal-reaching candidates."""
    from planners.learned.training.expert import GoalReachingExpert

    family, terrain, apex = instance(cfg, i)
    params = dataset_hopper(cfg)
    expert = GoalReachingExpert(spacing=terrain.cell / cfg.subcells, max_nodes=cfg.expert_max_nodes,
                                look_ahead=cfg.expert_look_ahead)
    policy = None
    if cfg.policy:
        from planners.learned.lstm import LSTMPlanner

        policy = LSTMPlanner(model=cfg.policy, max_steps=1, ranker=None, controller=expert.controller)
    states = expert.rollout(apex, terrain, dataset_goal(cfg), params, np.random.default_rng([cfg.seed, i, 2]),
                            cfg.explore, policy=policy)
    ode_calls = sum(label.ode_calls for _, label, _ in states)
    states = [s for s in states if s[1].choice >= 0]
    encs, steps, viable = [], [], []
    for k, (a, _, _) in enumerate(states):
        enc = encode_window(terrain, a, units_of(params))
        bins, sets = [], []
        for _, label, executed in states[k:k + cfg.max_steps]:
            b = int(enc.bin_of(label.foothold, cfg.subcells))
            if not 0 <= b < enc.terrain.size * cfg.subcells:
                break
            bins.append(b)
            sets.append(window_bins(enc, label.x_l[label.reaching], cfg.subcells))
            if executed != label.foothold:
                break
        if len(bins) >= cfg.min_steps:
            encs.append(enc)
            steps.append(np.array(bins))
            viable.append(np.array(sets))
    padded, sets = pack_sequences(steps, viable, 110 * cfg.subcells)
    n = len(encs)
    return {"terrain": np.array([e.terrain for e in encs]).reshape(n, 110),
            "apex": np.array([e.apex for e in encs]).reshape(n, 3),
            "s0": np.array([e.s0_bin(cfg.subcells) for e in encs], dtype=np.int16), "steps": padded,
            "viable": sets, "family": family, "ode_calls": ode_calls, "nodes": len(states)}


def shard_name(k: int) -> str:
    return f"shard_{k:05d}.npz"


def shard_path(folder: str, k: int) -> str:
    return os.path.join(folder, shard_name(k))


def make_shard(cfg: DatasetConfig, k: int, policy: bytes | None = None) -> dict:
    """Shard k (instances k*S .. k*S+S-1): {"arrays": the arrays of its .npz, "sequences", "seconds", "ode_calls"}.
    A task of ``generate``: it writes nothing, the driver saves what it returns (``save_shard``). ``policy``: the
    content of ``cfg.policy``'s weights file, for a worker that cannot read the driver's files (None: read
    ``cfg.policy`` itself)."""
    if policy is not None:
        cfg = replace(cfg, policy=local_copy(policy, ".pt"))
    t0 = time.perf_counter()
    first = k * cfg.instances_per_shard
    parts = [instance_sequences(cfg, i) for i in range(first, min(first + cfg.instances_per_shard, cfg.n_instances))]
    t_max = max([p["steps"].shape[1] for p in parts] + [1])
    arrays = {
        "terrain": np.concatenate([p["terrain"] for p in parts]).reshape(-1, 110).astype(np.float32),
        "apex": np.concatenate([p["apex"] for p in parts]).reshape(-1, 3).astype(np.float32),
        "s0": np.concatenate([p["s0"] for p in parts]).astype(np.int16),
        "steps": np.concatenate([pad_steps(p["steps"], t_max, -1) for p in parts]).astype(np.int16),
        "subcells": np.array(cfg.subcells, dtype=np.int16),  # bins per cell of s0 and steps
        # viable[j, i]: bit b set if the search found bin b viable for step i (its siblings), packed along bins
        "viable": np.packbits(np.concatenate([pad_steps(p["viable"], t_max) for p in parts]), axis=-1),
    }
    return {"arrays": arrays, "sequences": int(arrays["steps"].shape[0]), "seconds": time.perf_counter() - t0,
            "ode_calls": int(sum(p["ode_calls"] for p in parts))}


def save_shard(path, shard: dict) -> None:
    """Write a shard ``make_shard`` returned as one compressed .npz, atomically (the driver's side)."""
    with atomic_write(path) as f:
        np.savez_compressed(f, **shard["arrays"])


def shard_store(folder) -> FileStore:
    """The shards of a dataset folder as a store of the job runner, keyed by shard index."""
    return FileStore(folder, shard_name, save_shard)


def generate(cfg: DatasetConfig, folder, executor=None):
    """Generate the dataset in ``folder`` on ``executor`` (``drakeslip.jobs.executors``; default this process):
    the config is recorded first (a folder made with another raises ValueError, before any shard is made), then
    ``(k, statistics)`` is yielded for every shard, None for one already on disk, else its dict from
    ``make_shard`` without the arrays, once the driver has written it."""
    write_manifest(cfg, folder)
    policy = Path(cfg.policy).read_bytes() if cfg.policy else None
    tasks = [(k, (cfg, k, policy)) for k in range(cfg.n_shards)]
    return ((k, None if isinstance(shard, str) else statistics(k, shard))  # a str: the path of a shard on disk
            for k, shard in run(make_shard, tasks, shard_store(folder), executor))


def statistics(k: int, shard: dict) -> dict:
    """What ``make_shard`` returned for shard k, less its arrays."""
    return {"shard": k, **{name: value for name, value in shard.items() if name != "arrays"}}


def write_shard(cfg: DatasetConfig, k: int, folder: str) -> dict:
    """Make shard k in this process and write it atomically; returns its statistics (without the arrays)."""
    shard = make_shard(cfg, k)
    shard_store(folder).put(k, shard)
    return statistics(k, shard)


def local_copy(content: bytes, suffix: str = "") -> str:
    """A file holding ``content`` in this machine's temporary folder, named by its digest, for a loader that takes
    a path: a task gets the input files it needs as bytes from the driver (no filesystem is shared with it) and
    reads them from here. Written atomically once per machine and content, and reused."""
    path = Path(tempfile.gettempdir()) / f"drakeslip-input-{hashlib.sha256(content).hexdigest()[:24]}{suffix}"
    if not path.is_file() or path.stat().st_size != len(content):
        with atomic_write(path) as f:
            f.write(content)
    return str(path)


def write_manifest(cfg: DatasetConfig, folder: str) -> None:
    """Record the config; a folder made with another config is refused rather than silently mixed."""
    path = os.path.join(folder, "config.json")
    mine = asdict(cfg)
    for name in ("families", "cost_weights", "height_range", "speed_range"):
        mine[name] = list(mine[name])  # as JSON reads them back
    if os.path.exists(path):
        defaults = {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(DatasetConfig()).items()}
        recorded = read_json(path, "dataset config")
        if not isinstance(recorded, dict):
            raise ValueError(f"dataset config {path} is not a JSON object")
        theirs = {**defaults, **recorded}  # fields a folder predates have their defaults
        if theirs != mine:
            raise ValueError(f"{folder} holds a dataset made with another config ({path}); use a new folder")
        return
    with atomic_write(path, "w") as f:
        json.dump(mine, f, indent=1)


def pending_shards(cfg: DatasetConfig, folder: str) -> list[int]:
    return [k for k in range(cfg.n_shards) if not os.path.exists(shard_path(folder, k))]


def count_sequences(folder: str) -> int:
    total = 0
    for name in sorted(os.listdir(folder)):
        if name.startswith("shard_") and name.endswith(".npz"):
            with np.load(os.path.join(folder, name)) as shard:
                total += shard["s0"].shape[0]
    return total
