"""The CNN+LSTM footstep model, its dataset generation and training, and the LSTM planner."""
import math

import numpy as np
import pytest
import torch

import drakeslip as ds
from planners.learned.training.dataset import DatasetConfig, count_sequences, pending_shards, shard_path, write_manifest, write_shard
from planners.learned.inference import PlanningFootstepModel
from planners.learned.inputs import encode_window
from planners.learned.model import FootstepModel, ModelConfig, load_checkpoint
from planners.learned.training.train_lstm import TrainConfig, batch_loss, load_dataset, one_hot_inputs, train

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


def test_subcell_model_has_bins_and_reads_the_previous_step_per_bin():
    torch.manual_seed(0)
    cfg = ModelConfig(subcells=4)
    model = FootstepModel(cfg).eval()
    assert cfg.n_bins == 440
    terrain, apex = torch.randn(1, 110), torch.randn(1, 3)
    first, second = torch.zeros(1, 1, 440), torch.zeros(1, 1, 440)
    first[0, 0, 200], second[0, 0, 201] = 1.0, 1.0  # two bins of the same cell
    a, b = model(terrain, apex, first)[0], model(terrain, apex, second)[0]
    assert a.shape == (1, 1, 440)
    assert not torch.allclose(a, b)  # the model tells apart where in a cell the last step was


@pytest.mark.parametrize("subcells", [1, 4])
def test_the_planners_inference_matches_torch(subcells):
    """The compiled forward pass the planners run (planners/core/model.py) against the torch model it is trained as."""
    torch.manual_seed(1)
    model = FootstepModel(ModelConfig(subcells=subcells)).eval()
    n = 110 * subcells
    terrain, apex = torch.rand(3, 110) - 0.5, torch.rand(3, 3)
    s0 = torch.zeros(3, n)
    s0[:, 30 * subcells] = 1.0
    mask = torch.zeros(3, n, dtype=torch.bool)
    mask[:, 40:45] = True
    expected = model.rollout(terrain, apex, s0, 5, mask, temperature=1.5).numpy()
    got = PlanningFootstepModel(model).rollout(terrain.double().numpy(), apex.double().numpy(), s0.double().numpy(),
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
        assert enc.bin_of(x) == 30
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
    data, subcells = load_dataset(tiny_dataset)
    assert subcells == 1
    lengths = (data["steps"] >= 0).sum(1)
    assert lengths.min() >= 1
    assert np.all(data["s0"] == 30)
    firsts = data["steps"][:, 0]
    assert np.all(firsts >= 20)  # the first foothold is near or ahead of the body, never far behind


def test_dataset_selectors_split_ditch_windows_from_the_rest(tiny_dataset):
    """``FOLDER:ditch`` and ``FOLDER:no-ditch`` partition the sequences (the tiny set has a ditch and a step
    terrain); an unknown selector names itself."""
    full = load_dataset(tiny_dataset)[0]
    ditch, rest = load_dataset(tiny_dataset + ":ditch")[0], load_dataset(tiny_dataset + ":no-ditch")[0]
    assert ditch["s0"].size > 0 and rest["s0"].size > 0
    assert ditch["s0"].size + rest["s0"].size == full["s0"].size
    assert (ditch["terrain"] == -1.0).any(axis=1).all() and not (rest["terrain"] == -1.0).any()
    assert ditch["steps"].shape[0] == ditch["apex"].shape[0] == ditch["viable"].shape[0]
    with pytest.raises(ValueError, match="'steps'"):
        load_dataset(tiny_dataset + ":steps")


def test_step_space_sequences_move_forward_and_bad_configs_are_refused():
    from planners.learned.training.dataset import instance_sequences

    cfg = DatasetConfig(planner="step", min_steps=3, n_terrains=1, apexes_per_terrain=2, max_nodes=200, seed=4)
    rows = [s[s >= 0] for i in range(cfg.n_instances) for s in instance_sequences(cfg, i)["steps"]]
    assert rows and all(r.size >= 3 and np.all(np.diff(r) >= 0) for r in rows)
    with pytest.raises(ValueError, match="planner"):
        DatasetConfig(planner="dijkstra")
    with pytest.raises(ValueError, match="speed_range"):
        DatasetConfig(speed_range=(2.0, 1.0))


def test_subcell_labels_are_the_exact_footholds():
    """With subcells=4 the Step-space data planner's grid is the bins' centres: a label bin gives back its
    foothold exactly, which is what lets the mode of a sub-cell model replay a planned sequence."""
    from planners.learned.training.dataset import instance, instance_sequences, search_tree

    cfg = DatasetConfig(planner="step", subcells=4, min_steps=3, n_terrains=1, apexes_per_terrain=1,
                        max_nodes=200, seed=4)
    family, terrain, apex = instance(cfg, 0)
    enc = encode_window(terrain, apex)
    result, _ = search_tree(cfg, 0, apex, terrain)
    footholds = np.concatenate([seq.footholds for seq in result.tree.paths()])
    assert footholds.size
    np.testing.assert_allclose(enc.x_of_bin(enc.bin_of(footholds, 4), 4), footholds, atol=1e-9)
    arrays = instance_sequences(cfg, 0)
    assert np.all(arrays["s0"] == enc.s0_bin(4)) and 120 <= enc.s0_bin(4) < 124
    assert arrays["steps"].max() < 440
    steps, viable = arrays["steps"], arrays["viable"]
    rows, cols = np.nonzero(steps >= 0)
    assert np.all(viable[rows, cols, steps[rows, cols]])  # a label is one of its step's viable bins
    assert not viable[steps < 0].any()


def test_soft_targets_spread_over_the_viable_set():
    from planners.learned.training.train_lstm import soft_targets

    sets = np.zeros((1, 2, 16), dtype=bool)
    sets[0, 0, [3, 5, 7]] = True
    steps = torch.tensor([[5, -1]])
    q = soft_targets(steps, torch.from_numpy(np.packbits(sets, axis=-1)), 16, 0.5)
    assert q.shape == (1, 2, 16)
    assert float(q[0, 0].sum()) == pytest.approx(1.0) and float(q[0, 1].sum()) == 0.0
    assert float(q[0, 0, 5]) == pytest.approx(0.5 + 0.5 / 3) and float(q[0, 0, 3]) == pytest.approx(0.5 / 3)


def test_optimizer_steps_lower_the_loss_on_their_batch():
    """The real loss path (a share of the sequences fed the model's own distributions) trains: AdamW steps on one
    batch of sequences lower its loss (tests/test_bench_planners.py times one such step on 256 sequences)."""
    torch.manual_seed(0)
    model = FootstepModel()
    opt = torch.optim.AdamW(model.parameters(), lr=1e-3)
    n = model.config.n_cells
    batch = {"terrain": torch.rand(32, n) - 0.5, "apex": torch.rand(32, 3), "s0": torch.full((32,), 30),
             "steps": torch.randint(31, n, (32, 12))}
    losses = []
    for _ in range(4):
        loss = batch_loss(model, batch, own_inputs=0.3)[0]
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        losses.append(loss.item())
    assert losses[-1] < losses[0], losses


def test_tiny_end_to_end_train_and_plan(tiny_dataset, tmp_path):
    cfg = TrainConfig(data=tiny_dataset, out=str(tmp_path / "lstm.pt"), checkpoint=str(tmp_path / "ck.pt"),
                      epochs=2, batch_size=32, seed=0)
    summary = train(cfg, log=lambda *_: None)
    assert len(summary["history"]) == 2 and np.isfinite(summary["best_val_loss"])
    cfg.epochs = 3  # resume continues from the checkpoint instead of starting over
    assert len(train(cfg, log=lambda *_: None)["history"]) == 3
    other = TrainConfig(**{**cfg.__dict__, "lr": cfg.lr / 2, "epochs": 4})   # another run's settings: not resumed
    with pytest.raises(ValueError, match="another training setup"):
        train(other, log=lambda *_: None)
    import planners

    planner = planners.make("lstm@paper", model=cfg.out)
    terrain = ds.step_world(11)
    plan = planner.plan((0.0, 0.75, 1.5), terrain, 10.0, ds.SlipParams())
    # The planner takes the most probable usable foothold (solid, off edges, ahead of the last one, the first
    # reached inside the friction cone). A softmax gives every bin outside a ditch a positive probability, so any
    # model, however little trained, plans wherever such a foothold exists, as it does from this apex on the flat
    # run-up of this step world: the plan must be found, and its footholds usable.
    assert plan.success and plan.ode_calls == 0, plan.message
    assert np.all(plan.footholds < 8.0 + 1e-9) and plan.footholds[0] > -0.5 and np.all(np.diff(plan.footholds) > 0)
    assert np.isfinite(plan.leg_angles[0]) and abs(plan.leg_angles[0]) < math.atan(ds.SlipParams().friction)
    probs, xs = planner.distributions((0.0, 0.75, 1.5), terrain, 4)
    assert probs.shape == (4, 110) and xs.shape == (110,)
    np.testing.assert_allclose(probs.sum(1), 1.0, rtol=1e-5)


def test_training_width_is_configurable(tiny_dataset, tmp_path):
    """examples/train_lstm.py --hidden/--channels: the checkpoint records the width and loads back."""
    cfg = TrainConfig(data=tiny_dataset, out=str(tmp_path / "wide.pt"), checkpoint="", epochs=1, batch_size=32)
    train(cfg, log=lambda *_: None, width=(24, 3))
    model, _ = load_checkpoint(cfg.out)
    assert (model.config.hidden, model.config.channels) == (24, 3)


def test_fine_tuning_starts_from_the_given_weights(tiny_dataset, tmp_path):
    """examples/train_lstm.py --init: with a zero learning rate the fine-tuned weights are the initial ones
    (a fresh model would differ); several dataset folders load as one."""
    first = TrainConfig(data=tiny_dataset, out=str(tmp_path / "a.pt"), checkpoint="", epochs=1, batch_size=32)
    train(first, log=lambda *_: None, width=(24, 3))
    tuned = TrainConfig(data=f"{tiny_dataset},{tiny_dataset}", out=str(tmp_path / "b.pt"), checkpoint="", epochs=1,
                        batch_size=32, lr=0.0, weight_decay=0.0, init=first.out)
    summary = train(tuned, log=lambda *_: None)
    assert summary["n_train"] + summary["n_val"] == 2 * load_dataset(tiny_dataset)[0]["s0"].size
    a, b = load_checkpoint(first.out)[0].state_dict(), load_checkpoint(tuned.out)[0].state_dict()
    assert all(torch.equal(a[k], b[k]) for k in a)


def test_learned_planners_with_the_committed_weights():
    """The committed model plans a ditch terrain: LSTM-guided within the controller's reach and with far fewer
    step-map calls than Step-space, deterministically; the LSTM's footholds are usable (ahead of each other,
    off edges, the first inside the friction cone)."""
    import planners
    from planners.search.tree import clear_of_edges

    terrain, apex, params = ds.ditch_world(1003).perceived(0.0), (0.0, 0.9, 2.0), ds.SlipParams(friction=0.8)
    guided = planners.make("lstm-guided@paper")
    plan = guided.plan(apex, terrain, 10.0, params)
    assert plan.success, plan.message
    assert plan.ode_calls < planners.make("step").plan(apex, terrain, 10.0, params).ode_calls
    assert guided.plan(apex, terrain, 10.0, params).footholds.tolist() == plan.footholds.tolist()
    lazy = planners.make("lstm-guided@paper", lazy=True).plan(apex, terrain, 10.0, params)
    assert lazy.success and lazy.ode_calls <= plan.ode_calls  # one candidate simulated at a time
    restarted = planners.make("lstm-guided@paper", lazy=True, conditioning="apex").plan(apex, terrain, 10.0, params)
    assert restarted.success and restarted.ode_calls <= lazy.ode_calls
    with pytest.raises(ValueError, match="conditioning"):
        planners.make("lstm-guided", conditioning="future")
    reached = ds.step_batch(apex, plan.leg_angles[:1], terrain, params)
    assert reached.ok[0] and abs(reached.touchdown_x[0] - plan.footholds[0]) < 0.02

    lstm = planners.make("lstm@paper").plan(apex, terrain, 10.0, params)
    assert lstm.success and lstm.ode_calls == 0
    assert np.all(np.diff(lstm.footholds) > 0)
    assert np.all(clear_of_edges(terrain, lstm.footholds, 0.02))
    assert abs(lstm.leg_angles[0]) < math.atan(params.friction)


def test_lstm_guided_takes_cost_weights_beside_its_checkpoint():
    """``model`` names the LSTM checkpoint; the node cost's weights are ``cost_weights``, as Step-space's."""
    import planners
    from planners.checkpoints import PAPER_WEIGHTS
    from planners.search.tree import CostWeights

    guided = planners.make("lstm-guided", model=str(PAPER_WEIGHTS), cost_weights=(1, 0, 2))
    assert guided.cost_weights == CostWeights(1, 0, 2)
    assert planners.make("lstm-guided").cost_weights == planners.make("step").cost_weights
    terrain, apex = ds.Terrain.flat(), (0.0, 0.9, 2.0)
    plan = guided.plan(apex, terrain, 4.0, ds.SlipParams(friction=0.8))
    assert plan.success, plan.message
