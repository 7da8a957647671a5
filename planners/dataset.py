"""Training data for the footstep model: search trees turned into footstep sequences (Table I).

Each instance is one terrain and one initial apex. Its search tree (Angle-space, as in the paper, or
Step-space, see DatasetConfig.planner) is grown to ``goal_sequences`` goals, and every root-to-leaf path with at
least ``min_steps`` footholds that covers at least ``min_progress`` of the distance to the search target becomes a
sequence: the encoded perception window at the initial apex and the window cells of its footholds. With every
step goes its viable set, the cells of all the footholds the search found viable from the same apex (the step's
siblings in the tree), which training can use as soft labels (TrainConfig.viable_weight). Instances are grouped
into shards; each shard is written atomically as one .npz, so an interrupted run resumes by skipping the shards
already on disk. With ``planner="expert"`` the sequences come from rollouts of the goal-reaching expert instead
(``expert_sequences``), whose viable sets are each state's goal-reaching footholds.
"""
from __future__ import annotations

import json
import os
import time
from dataclasses import asdict, dataclass

import numpy as np

from drakeslip import ApexState, SlipParams, TERRAIN_FAMILIES
from drakeslip.files import atomic_write

from .angle_space import AngleSpacePlanner
from .expert import GoalReachingExpert
from .lstm_planner import LSTMPlanner
from .step_space import StepSpacePlanner
from .lstm_inputs import encode_window, pad_steps


@dataclass(frozen=True)
class DatasetConfig:
    """The paper's Table I by default."""

    planner: str = "angle"              # "angle": the paper's; "step": Step-space trees; "expert": rollouts of
                                        # the goal-reaching expert (planners/expert.py; see README, LSTM)
    n_terrains: int = 360               # half ditch world, half step world
    apexes_per_terrain: int = 8
    min_steps: int = 8
    goal_sequences: int = 8             # d: goals each search collects
    branching: int = 15
    friction: float = 0.6               # lower than the test suites' 0.8, for robustness
    weights: tuple = (1.0, 1.0, 2.0)
    goal_x: float = 10.0
    min_progress: float = 0.6           # fraction of the distance from the apex to the search target
    max_paths_per_instance: int = 20    # seeded subsample of an instance's paths (~50k sequences in all)
    max_steps: int = 20                 # sequences are cut to their first max_steps footholds
    max_nodes: int = 2000
    max_time_s: float = 20.0
    # initial apex: x from start_x on (a quarter on the first half metre), height above the ground under it
    # and forward speed uniform in these ranges (the committed model's; examples/generate_dataset.py --help)
    start_x: float = 0.0
    height_range: tuple = (0.55, 0.85)
    speed_range: tuple = (0.4, 2.6)
    families: tuple = ("ditch", "step")
    # output bins per 10 cm cell: 1 is the paper's. With the Step-space planner and subcells > 1 its foothold
    # grid is the bins' centres (no fallback grid), so a label bin is the exact foothold (see README, LSTM)
    subcells: int = 1
    instances_per_shard: int = 16
    seed: int = 0
    explore: float = 0.3                # "expert": chance a rollout hops to a random goal-reaching foothold
    expert_max_nodes: int = 300         # "expert": node budget of its searches (GoalReachingExpert)
    expert_look_ahead: bool = False     # "expert": label with the foothold that leaves the most room a hop later
    policy: str = ""                    # "expert": weights of a footstep model whose one-step mode planner the
                                        # rollouts follow where it stays goal-reaching (DAgger; expert.py)

    def __post_init__(self):
        if self.planner not in ("angle", "step", "expert"):
            raise ValueError(f"DatasetConfig.planner must be 'angle', 'step' or 'expert', got {self.planner!r}")
        if self.policy and self.planner != "expert":
            raise ValueError(f"DatasetConfig.policy is for planner='expert', not {self.planner!r}")
        if self.expert_look_ahead and self.planner != "expert":
            raise ValueError(f"DatasetConfig.expert_look_ahead is for planner='expert', not {self.planner!r}")
        if self.policy and not os.path.isfile(self.policy):
            raise ValueError(f"DatasetConfig.policy: no weights file {self.policy!r}")
        if not 0.0 <= self.explore <= 1.0:
            raise ValueError(f"DatasetConfig.explore must be a probability, got {self.explore!r}")
        for name in ("height_range", "speed_range"):
            lo, hi = getattr(self, name)
            if not 0 < lo <= hi:
                raise ValueError(f"DatasetConfig.{name} must be 0 < low <= high, got {getattr(self, name)!r}")
        unknown = [f for f in self.families if f not in TERRAIN_FAMILIES]
        if unknown:
            raise ValueError(f"unknown terrain family {unknown[0]!r}; known: {sorted(TERRAIN_FAMILIES)}")
        for name in ("n_terrains", "apexes_per_terrain", "min_steps", "goal_sequences", "branching",
                     "instances_per_shard", "max_paths_per_instance", "max_steps", "subcells", "expert_max_nodes"):
            if getattr(self, name) < 1:
                raise ValueError(f"DatasetConfig.{name} must be at least 1, got {getattr(self, name)}")

    @property
    def n_instances(self) -> int:
        return self.n_terrains * self.apexes_per_terrain

    @property
    def n_shards(self) -> int:
        return -(-self.n_instances // self.instances_per_shard)


def instance(cfg: DatasetConfig, i: int):
    """Terrain and initial apex of instance i: terrain i // apexes_per_terrain, families alternating."""
    t = i // cfg.apexes_per_terrain
    family = cfg.families[t % len(cfg.families)]
    terrain = TERRAIN_FAMILIES[family](seed=cfg.seed * 1_000_003 + t)
    rng = np.random.default_rng([cfg.seed, i])
    for _ in range(100):  # start over solid ground: near the start or anywhere along the course
        x = rng.uniform(cfg.start_x, 0.5) if rng.random() < 0.25 else rng.uniform(cfg.start_x, cfg.goal_x - 2.0)
        if not terrain.is_ditch_at(x):
            break
    apex = ApexState(x, terrain.height_at(x) + rng.uniform(*cfg.height_range), rng.uniform(*cfg.speed_range))
    return family, terrain, apex


def search_tree(cfg: DatasetConfig, i: int, apex, terrain):
    """The search of instance i, with the dataset's friction; returns (SearchResult, planner horizon)."""
    params = SlipParams(friction=cfg.friction)
    budget = {"max_nodes": cfg.max_nodes, "max_time_s": cfg.max_time_s}
    if cfg.planner == "angle":
        planner = AngleSpacePlanner(branching=cfg.branching, fallback=(), n_sequences=cfg.goal_sequences,
                                    weights=cfg.weights, seed=cfg.seed * 7919 + i, **budget)
    elif cfg.subcells > 1:
        planner = StepSpacePlanner(spacing=terrain.cell / cfg.subcells, fallback_spacing=(),
                                   n_sequences=cfg.goal_sequences, weights=cfg.weights, **budget)
    else:
        planner = StepSpacePlanner(n_sequences=cfg.goal_sequences, weights=cfg.weights, **budget)
    return planner.search(apex, terrain, cfg.goal_x, params), planner.horizon


def instance_sequences(cfg: DatasetConfig, i: int) -> dict:
    """All qualifying sequences of instance i as arrays (terrain, apex, s0, steps), plus search statistics;
    s0 and steps are output bins (cells when cfg.subcells is 1)."""
    if cfg.planner == "expert":
        return expert_sequences(cfg, i)
    family, terrain, apex = instance(cfg, i)
    result, horizon = search_tree(cfg, i, apex, terrain)
    enc = encode_window(terrain, apex)
    target = min(cfg.goal_x, apex.x + horizon - 1.0)
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
    family, terrain, apex = instance(cfg, i)
    params = SlipParams(friction=cfg.friction)
    expert = GoalReachingExpert(spacing=terrain.cell / cfg.subcells, max_nodes=cfg.expert_max_nodes,
                                look_ahead=cfg.expert_look_ahead)
    policy = LSTMPlanner(weights=cfg.policy, max_steps=1, controller=expert.controller) if cfg.policy else None
    states = expert.rollout(apex, terrain, cfg.goal_x, params, np.random.default_rng([cfg.seed, i, 2]), cfg.explore,
                            policy=policy)
    ode_calls = sum(label.ode_calls for _, label, _ in states)
    states = [s for s in states if s[1].choice >= 0]
    encs, steps, viable = [], [], []
    for k, (a, _, _) in enumerate(states):
        enc = encode_window(terrain, a)
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


def shard_path(folder: str, k: int) -> str:
    return os.path.join(folder, f"shard_{k:05d}.npz")


def write_shard(cfg: DatasetConfig, k: int, folder: str) -> dict:
    """Generate shard k (instances k*S .. k*S+S-1) and write it atomically; returns its statistics."""
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
    with atomic_write(shard_path(folder, k)) as f:
        np.savez_compressed(f, **arrays)
    return {"shard": k, "sequences": int(arrays["steps"].shape[0]), "seconds": time.perf_counter() - t0,
            "ode_calls": int(sum(p["ode_calls"] for p in parts))}


def write_manifest(cfg: DatasetConfig, folder: str) -> None:
    """Record the config; a folder made with another config is refused rather than silently mixed."""
    path = os.path.join(folder, "config.json")
    mine = asdict(cfg)
    for name in ("families", "weights", "height_range", "speed_range"):
        mine[name] = list(mine[name])  # as JSON reads them back
    if os.path.exists(path):
        with open(path) as f:
            defaults = {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(DatasetConfig()).items()}
            theirs = {**defaults, **json.load(f)}  # fields a folder predates have their defaults
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
