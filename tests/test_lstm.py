"""The CNN+LSTM footstep model, its dataset generation and training, and the LSTM planner."""

import numpy as np
import pytest
import torch

import drakeslip as ds
from planners.dataset import DatasetConfig, count_sequences, pending_shards, shard_path, write_manifest, write_shard
from planners.lstm_inference import NumpyFootstepModel
from planners.lstm_inputs import encode_window
from planners.lstm_model import FootstepModel, ModelConfig, load_checkpoint
from planners.lstm_train import TrainConfig, batch_loss, load_dataset, one_hot_inputs, train

TINY = DatasetConfig(n_terrains=2, apexes_per_terrain=2, instances_per_shard=1, seed=1)


def test_model_shapes_and_initial_state():
    cfg = ModelConfig()
    model = FootstepModel(cfg)
    b, t, n = 4, 6, cfg.n_cells
    logits, (h, c) = model(torch.randn(b, n), torch.randn(b, 3), torch.softmax(torch.randn(b, t, n), -1))
    assert logits.shape == (b, t, n)
    assert h.shape == c.shape == (cfg.layers, b, cfg.hidden)
    h0, c0 = model.initial_state(torch.randn(b, 3))
    assert h0.shape == (cfg.layers, b, cfg.hidden) and not torch.allclose(h0, c0)


def test_rollout_is_a_distribution_and_respects_the_mask():
    model = FootstepModel()
    n = model.config.n_cells
    s0 = torch.zeros(1, n)
    s0[0, 30] = 1
    mask = torch.zeros(1, n, dtype=torch.bool)
    mask[0, 40:60] = True
    probs = model.rollout(torch.randn(1, n), torch.randn(1, 3), s0, 5, mask)
    assert probs.shape == (1, 5, n)
    assert torch.allclose(probs.sum(-1), torch.ones(1, 5))
    assert probs[0, :, 40:60].max() == 0


def test_numpy_inference_matches_torch():
    torch.manual_seed(1)
    model = FootstepModel(ModelConfig()).eval()
    terrain, apex = torch.rand(3, 110) - 0.5, torch.rand(3, 3)
    s0 = torch.zeros(3, 110)
    s0[:, 30] = 1.0
    mask = torch.zeros(3, 110, dtype=torch.bool)
    mask[:, 40:45] = True
    expected = model.rollout(terrain, apex, s0, 5, mask, temperature=1.5).numpy()
    got = NumpyFootstepModel(model).rollout(terrain.double().numpy(), apex.double().numpy(), s0.double().numpy(),
                                            5, mask.numpy(), temperature=1.5)
    assert np.abs(got - expected).max() < 1e-5
    assert np.all(got[:, :, 40:45] == 0.0)


def test_padding_does_not_change_the_loss():
    torch.manual_seed(0)
    model = FootstepModel()
    n = model.config.n_cells
    steps = torch.tensor([[35, 41, 47, -1]])
    batch = {"terrain": torch.randn(1, n), "apex": torch.randn(1, 3), "s0": torch.tensor([30]), "steps": steps}
    short = dict(batch, steps=steps[:, :3])
    assert torch.isclose(batch_loss(model, batch)[0], batch_loss(model, short)[0])
    prev = one_hot_inputs(batch["s0"], steps, n)
    assert prev[0, 0, 30] == 1 and prev[0, 3, 47] == 1 and prev[0].sum() == 4


def test_corrupt_and_mismatched_weights_are_rejected(tmp_path):
    bad = tmp_path / "garbage.pt"
    bad.write_bytes(b"not a checkpoint at all")
    with pytest.raises(ValueError, match="garbage.pt"):
        load_checkpoint(bad)
    other = tmp_path / "other.pt"
    torch.save({"format": "drakeslip-lstm/1", "config": {"hidden": 50},
                "state_dict": FootstepModel().state_dict()}, other)
    with pytest.raises(ValueError, match="does not match"):
        load_checkpoint(other)
    foreign = tmp_path / "foreign.pt"
    torch.save({"weights": 1}, foreign)
    with pytest.raises(ValueError, match="not a drakeslip LSTM checkpoint"):
        load_checkpoint(foreign)


def test_window_encoding_puts_the_body_in_cell_30():
    terrain = ds.step_world(4)
    for x in np.linspace(0.0, 9.0, 37):
        enc = encode_window(terrain, ds.ApexState(x, terrain.height_at(x) + 0.7, 1.2))
        assert enc.s0 == 30 and enc.terrain.shape == (110,)
        assert enc.cell_of(x) == 30
        assert enc.apex[0] == pytest.approx(0.7, abs=1e-6)


@pytest.fixture(scope="module")
def tiny_dataset(tmp_path_factory):
    folder = str(tmp_path_factory.mktemp("footsteps"))
    write_manifest(TINY, folder)
    for k in pending_shards(TINY, folder):
        write_shard(TINY, k, folder)
    return folder


def test_resumed_generation_loses_nothing(tiny_dataset, tmp_path):
    folder = str(tmp_path / "resumed")
    write_manifest(TINY, folder)
    write_shard(TINY, 1, folder)                       # a run that finished shard 1, then was killed
    (tmp_path / "resumed" / "shard_00002.npz.tmp").write_bytes(b"half-written")  # ... while writing shard 2
    assert pending_shards(TINY, folder) == [0, 2, 3]
    for k in pending_shards(TINY, folder):
        write_shard(TINY, k, folder)
    assert pending_shards(TINY, folder) == []
    for k in range(TINY.n_shards):
        a, b = np.load(shard_path(tiny_dataset, k)), np.load(shard_path(folder, k))
        for key in ("terrain", "apex", "s0", "steps"):
            np.testing.assert_array_equal(a[key], b[key])
    assert count_sequences(folder) == count_sequences(tiny_dataset) > 0
    with pytest.raises(ValueError, match="another config"):
        write_manifest(DatasetConfig(seed=2), folder)


def test_dataset_sequences_are_valid(tiny_dataset):
    data = load_dataset(tiny_dataset)
    lengths = (data["steps"] >= 0).sum(1)
    assert lengths.min() >= 1
    assert np.all(data["s0"] == 30)
    firsts = data["steps"][:, 0]
    assert np.all(firsts >= 20)  # the first foothold is near or ahead of the body, never far behind


def test_step_space_sequences_move_forward_and_bad_configs_are_refused():
    from planners.dataset import instance_sequences

    cfg = DatasetConfig(planner="step", min_steps=3, n_terrains=1, apexes_per_terrain=2, max_nodes=200, seed=4)
    rows = [s[s >= 0] for i in range(cfg.n_instances) for s in instance_sequences(cfg, i)["steps"]]
    assert rows and all(r.size >= 3 and np.all(np.diff(r) >= 0) for r in rows)
    with pytest.raises(ValueError, match="planner"):
        DatasetConfig(planner="dijkstra")
    with pytest.raises(ValueError, match="speed_range"):
        DatasetConfig(speed_range=(2.0, 1.0))


def test_tiny_end_to_end_train_and_plan(tiny_dataset, tmp_path):
    cfg = TrainConfig(data=tiny_dataset, out=str(tmp_path / "lstm.pt"), checkpoint=str(tmp_path / "ck.pt"),
                      epochs=2, batch_size=32, seed=0)
    summary = train(cfg, log=lambda *_: None)
    assert len(summary["history"]) == 2 and np.isfinite(summary["best_val_loss"])
    cfg.epochs = 3  # resume continues from the checkpoint instead of starting over
    assert len(train(cfg, log=lambda *_: None)["history"]) == 3
    import planners

    planner = planners.make("lstm", weights=cfg.out)
    terrain = ds.step_world(11)
    plan = planner.plan((0.0, 0.75, 1.5), terrain, 10.0, ds.SlipParams())
    assert plan.ode_calls == 0
    if plan.success:
        assert np.all(plan.footholds < 8.0 + 1e-9) and plan.footholds[0] > -0.5
        assert np.isfinite(plan.leg_angles[0])
    probs, xs = planner.distributions((0.0, 0.75, 1.5), terrain, 4)
    assert probs.shape == (4, 110) and xs.shape == (110,)
    np.testing.assert_allclose(probs.sum(1), 1.0, rtol=1e-5)


def test_learned_planners_with_the_committed_weights():
    """The committed model plans a ditch terrain: LSTM-guided within the controller's reach and with far fewer
    step-map calls than Step-space, deterministically; the LSTM's footholds are usable (ahead of each other,
    off edges, the first inside the friction cone)."""
    import math

    import planners
    from planners.evaluation import perceived
    from planners.search import clear_of_edges

    terrain, apex, params = perceived(ds.ditch_world(1003), 0.0), (0.0, 0.9, 2.0), ds.SlipParams(friction=0.8)
    guided = planners.make("lstm-guided")
    plan = guided.plan(apex, terrain, 10.0, params)
    assert plan.success, plan.message
    assert plan.ode_calls < planners.make("step").plan(apex, terrain, 10.0, params).ode_calls
    assert guided.plan(apex, terrain, 10.0, params).footholds.tolist() == plan.footholds.tolist()
    reached = ds.step_batch(apex, plan.leg_angles[:1], terrain, params)
    assert reached.ok[0] and abs(reached.touchdown_x[0] - plan.footholds[0]) < 0.02

    lstm = planners.make("lstm").plan(apex, terrain, 10.0, params)
    assert lstm.success and lstm.ode_calls == 0
    assert np.all(np.diff(lstm.footholds) > 0)
    assert np.all(clear_of_edges(terrain, lstm.footholds, 0.02))
    assert abs(lstm.leg_angles[0]) < math.atan(params.friction)
