"""The foothold ranker (planners/learned/ranker.py): its label, its use by the mode planner, its weights file and
its DAgger training script."""
import numpy as np
import pytest
import torch

import drakeslip as ds
from drakeslip.jobs.files import MANIFEST, manifest_entries, sha256
from planners import make
from planners.learned.ranker import N_FEATURES, ROOM_CAP, FootholdRanker, RankerNet, candidate_features, save_ranker
from planners.learned.training.labels import OneHopRoom
from planners.checkpoints import EXPERT_WEIGHTS, RANKER_WEIGHTS
from planners.learned.lstm import LSTMPlanner

PARAMS, APEX = ds.SlipParams(friction=0.8), ds.ApexState(0.0, 0.7, 1.0)
WINDOW = ds.ditch_world(1003).perceived(APEX.x)
RANK = 6  # the feature that holds a candidate's rank (0: most probable)


def rank_ranker(path, sign):
    """A ranker whose score is ``sign`` times the candidate's rank: +1 picks the least probable of the top k."""
    net = RankerNet(hidden=4)
    with torch.no_grad():
        for layer in net.mlp[::2]:
            layer.weight.zero_()
            layer.bias.zero_()
        net.mlp[0].weight[0, RANK] = 1.0
        net.mlp[2].weight[0, 0] = 1.0
        net.mlp[4].weight[0, 0] = sign
    save_ranker(path, net, np.zeros(N_FEATURES), np.ones(N_FEATURES))
    return path


class Recording(LSTMPlanner):
    def pick_first(self, problem, grid, score, theta):
        self.seen = grid[np.argsort(-score, kind="stable")][:int((score > 0).sum())]
        return super().pick_first(problem, grid, score, theta)


@pytest.mark.parametrize("top_k", [1, 2, 3])
def test_the_ranker_picks_among_the_top_k_first_footholds(tmp_path, top_k):
    last = Recording(model=EXPERT_WEIGHTS, max_steps=1, ranker=rank_ranker(tmp_path / "last.pt", 1.0), top_k=top_k)
    plan = last.plan(APEX, WINDOW, 10.0, PARAMS)
    assert plan.footholds.tolist() == [last.seen[top_k - 1]]
    first = make("lstm", model=EXPERT_WEIGHTS, max_steps=1, ranker=rank_ranker(tmp_path / "first.pt", -1.0), top_k=3)
    mode = make("lstm@no-ranker").plan(APEX, WINDOW, 10.0, PARAMS)
    assert first.plan(APEX, WINDOW, 10.0, PARAMS).footholds.tolist() == mode.footholds.tolist() == [last.seen[0]]
    assert plan.ode_calls == 0


def test_the_committed_ranker_plans_with_no_step_map_call():
    planner = make("lstm")  # the default: the expert model, one step, the committed ranker
    assert planner.ranker is not None and planner.max_steps == 1
    plan = planner.plan(APEX, WINDOW, 10.0, PARAMS)
    assert plan.success and plan.ode_calls == 0 and plan.footholds.size == 1
    assert plan.footholds.tolist() == make("lstm", model=EXPERT_WEIGHTS, ranker=RANKER_WEIGHTS).plan(
        APEX, WINDOW, 10.0, PARAMS).footholds.tolist()


def test_the_numpy_ranker_computes_the_torch_network(tmp_path):
    torch.manual_seed(0)
    net = RankerNet(hidden=16).eval()
    mean, std = np.linspace(-1, 1, N_FEATURES), np.linspace(0.5, 2, N_FEATURES)
    save_ranker(tmp_path / "r.pt", net, mean, std)
    features = np.random.default_rng(0).normal(size=(5, N_FEATURES))
    with torch.no_grad():
        expected = net(torch.tensor((features - mean) / std, dtype=torch.float32)).numpy()
    np.testing.assert_allclose(FootholdRanker(tmp_path / "r.pt").scores(features), expected, atol=1e-5)


def test_a_corrupt_or_mismatched_ranker_file_is_a_clear_error(tmp_path):
    (tmp_path / "junk.pt").write_bytes(b"not a checkpoint")
    with pytest.raises(ValueError, match="cannot read ranker weights file .*junk.pt"):
        FootholdRanker(tmp_path / "junk.pt")
    torch.save({"format": "something-else"}, tmp_path / "other.pt")
    with pytest.raises(ValueError, match="not a drakeslip ranker checkpoint"):
        FootholdRanker(tmp_path / "other.pt")
    save_ranker(tmp_path / "old.pt", RankerNet(hidden=4), np.zeros(N_FEATURES), np.ones(N_FEATURES))
    payload = torch.load(tmp_path / "old.pt", weights_only=False)
    payload["n_features"] = N_FEATURES - 1
    torch.save(payload, tmp_path / "old.pt")
    with pytest.raises(ValueError, match="does not match the ranker.*features"):
        FootholdRanker(tmp_path / "old.pt")
    with pytest.raises(ValueError, match="top_k must be a positive integer, got 0"):
        make("lstm", model=EXPERT_WEIGHTS, top_k=0)


def test_one_hop_room_labels_a_failed_hop_a_hop_past_the_target_and_one_with_room():
    planner = make("lstm@no-ranker")
    problem = planner.problem(APEX, WINDOW, 10.0, PARAMS, 0.0)
    mode = planner.plan(APEX, WINDOW, 10.0, PARAMS).footholds
    x = np.array([mode[0], mode[0], 0.3])
    theta = planner.controller.leg_angles(APEX, x, WINDOW)
    theta[2] = np.nan  # not aimed: the hop is not made
    room = OneHopRoom(planner.controller)(problem, x, theta)
    assert room[0] == room[1] and 1 <= room[0] <= ROOM_CAP and room[2] == -1
    near = planner.problem(APEX, WINDOW, 0.3, PARAMS, 0.0)  # a goal the mode's hop passes
    assert OneHopRoom(planner.controller)(near, x[:1], theta[:1]).tolist() == [ROOM_CAP]
    features = candidate_features(problem, x, np.log([0.5, 0.3, 0.2]), theta)
    assert features.shape == (3, N_FEATURES) and features[:, RANK].tolist() == [0, 1, 2]


def test_ranker_training_resumes_without_redoing_finished_work(tmp_path, example):
    script = example("train_ranker")
    args = ["--data-dir", str(tmp_path / "data"), "--out", str(tmp_path / "ranker.pt"), "--rounds", "2",
            "--terrains", "1", "--families", "ditch", "--epochs", "2", "--jobs", "1"]
    (tmp_path / MANIFEST).write_text(f"{'0' * 64}  ranker.pt\n")  # --out beside a manifest: its entry is rewritten
    script.main(args)
    assert manifest_entries(tmp_path) == {"ranker.pt": sha256(tmp_path / "ranker.pt")}
    shards = sorted((tmp_path / "data").glob("*.npz"))
    assert [p.name for p in shards] == ["round0-ditch-100000.npz", "round1-ditch-110000.npz"]
    before = {p.name: p.stat().st_mtime_ns for p in shards}
    first = FootholdRanker(tmp_path / "ranker.pt").layers
    (tmp_path / "data" / "round1-ditch-110000.npz").unlink()
    (tmp_path / "data" / "round1.pt").unlink()
    script.main(args)
    assert (tmp_path / "data" / "round0-ditch-100000.npz").stat().st_mtime_ns == before["round0-ditch-100000.npz"]
    for (w0, b0), (w1, b1) in zip(first, FootholdRanker(tmp_path / "ranker.pt").layers):
        np.testing.assert_array_equal(w0, w1)
        np.testing.assert_array_equal(b0, b1)
    with pytest.raises(SystemExit):
        script.main(args + ["--families", "ditch,lava"])
    with pytest.raises(SystemExit, match="made with other settings .top_k: 5, now 3"):
        script.main(args + ["--top-k", "3"])
    (tmp_path / "data" / "round1.pt").unlink()
    (tmp_path / "data" / "round1-ditch-110000.npz").write_bytes(b"cut short")
    with pytest.raises(ValueError, match="ranker data shard .*round1-ditch-110000.npz does not read"):
        script.main(args)
