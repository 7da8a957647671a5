"""The spatial footstep model: its compiled forward pass is the torch model's, its view reads the map as the module
says, the dataset's labels are distributions on the patch, and its committed weights load against their digest."""
import numpy as np
import pytest
import torch

import drakeslip as ds
from drakeslip.spatial.families import height_map_family
from drakeslip.spatial.heightmap import HeightMap
from planners.checkpoints import SPATIAL_WEIGHTS
from planners.core.spatial_model import LOWEST, cell_of_point, cell_points, logits_of, node_view, view_of
from planners.learned.config import SpatialModelConfig
from planners.learned.spatial_model import SpatialFootstepModel, load_spatial_checkpoint, save_spatial_checkpoint

P = ds.SlipParams()
VIEW = view_of(SpatialModelConfig(), P)


def test_the_compiled_pass_is_the_torch_model():
    torch.manual_seed(3)
    model = SpatialFootstepModel().double().eval()
    arrays = model.arrays()
    height_map = height_map_family("course")(4, 0.7)
    rng = np.random.default_rng(0)
    for _ in range(6):
        apex = (rng.uniform(0, 8), rng.uniform(-1, 1), 0.9, rng.uniform(0.5, 3), rng.uniform(-0.5, 0.5))
        history = rng.uniform(-2, 2, (rng.integers(0, 5), 2))
        patch, features, past = node_view(apex, history, len(history), (10.0, 0.0), height_map.ground(),
                                          P.as_array(), VIEW)
        with torch.no_grad():
            expected = model(*(torch.as_tensor(a[None]) for a in (patch, features, past)))[0].numpy()
        assert np.allclose(logits_of(patch, features, past, arrays).reshape(-1), expected, rtol=0, atol=1e-10)


def test_the_view_reads_holes_heights_and_the_history():
    heights = np.zeros((80, 200))
    heights[:, 60:70] = np.nan                       # a band of holes across x in [0, 0.5)
    height_map = HeightMap(heights, 0.05, (-3.0, -2.0))
    apex = (-0.5, 0.0, 0.9, 1.0, 0.0)
    history = np.array([[-2.0, 0.1], [-1.0, 0.0]])
    patch, features, past = node_view(apex, history, 2, (5.0, 0.0), height_map.ground(), P.as_array(), VIEW)
    holes = patch[1] > 0
    assert holes.any() and not holes.all() and np.all(patch[0][holes] == LOWEST)
    assert np.allclose(patch[0][~holes], (0.0 - 0.9) / P.leg_length)
    assert np.allclose(features[1:3], [1.0, 0.0]) and 0 < features[3] < 1
    assert np.allclose(past[0], [0, 0, 0]) and np.allclose(past[1:, 2], 1.0)
    assert np.allclose(past[2, :2], [-0.5 / P.leg_length, 0.0])
    for a, c in ((0, 0), (5, 7), (11, 11)):
        for x, y in cell_points(apex, a, c, height_map.ground(), P.as_array(), VIEW, 3):
            assert cell_of_point(apex, x, y, height_map.ground(), P.as_array(), VIEW) == (a, c)


def test_checkpoints_round_trip_and_refuse_a_changed_file(tmp_path):
    path = tmp_path / "model.pt"
    (tmp_path / "SHA256SUMS").write_text("")
    save_spatial_checkpoint(path, SpatialFootstepModel(), {"samples": 3})
    model, payload = load_spatial_checkpoint(path)
    assert payload["samples"] == 3 and model.config == SpatialModelConfig()
    path.write_bytes(path.read_bytes() + b"x")
    with pytest.raises(ValueError, match="SHA-256|digest"):
        load_spatial_checkpoint(path)


def test_the_committed_weights_load():
    model, payload = load_spatial_checkpoint(SPATIAL_WEIGHTS)
    assert payload["samples"] > 1000 and payload["held_out"]["top8"] > 0.5
