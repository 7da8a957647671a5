"""The step-length controller: foothold accuracy, batching, persistence and bad inputs."""
import numpy as np
import pytest
import torch

from drakeslip import SlipParams, Terrain, step, step_batch
from drakeslip.controller import StepLengthController


@pytest.fixture(scope="module")
def controller():
    return StepLengthController.load_default()


def _reachable(rng, n, terrain, params):
    """Footholds the hopper really lands on from random apexes (so the inverse exists)."""
    apex = np.stack([rng.uniform(-0.5, 0.5, n), rng.uniform(0.7, 1.2, n), rng.uniform(0.5, 3.0, n)], 1)
    theta = rng.uniform(-0.5, 0.6, n)
    res = step_batch(apex, theta, terrain, params)
    return apex[res.ok], res.touchdown_x[res.ok]


@pytest.mark.parametrize("terrain", [Terrain.flat(), Terrain(np.r_[np.zeros(33), np.full(80, -0.2)], x0=-3.0)],
                         ids=["flat", "step-down"])
def test_foothold_error_is_millimetres(controller, terrain):
    params = SlipParams()
    apex, target = _reachable(np.random.default_rng(0), 3000, terrain, params)
    theta = controller.leg_angles(apex, target, terrain)
    landed = step_batch(apex, theta, terrain, params).touchdown_x
    err = np.abs(landed - target)
    assert np.median(err) < 0.003 and np.quantile(err, 0.9) < 0.006 and err.max() < 0.03


def test_refinement_tightens_the_error(controller):
    """The Newton polish takes the MLP's millimetres of foothold error down to rounding: compared on the same
    targets with and without it."""
    terrain, params = Terrain.flat(), SlipParams()
    apex, target = _reachable(np.random.default_rng(1), 500, terrain, params)
    err = {refine: np.abs(step_batch(apex, controller.leg_angles(apex, target, terrain, refine=refine), terrain,
                                     params).touchdown_x - target) for refine in (False, True)}
    assert target.size > 100
    assert np.quantile(err[False], 0.9) > 5e-4  # the MLP alone: about 1.5 mm
    assert np.quantile(err[True], 0.9) < 1e-9 and err[True].max() < 1e-6
    assert np.all(err[True] <= err[False] + 1e-12)


def test_scalar_matches_batch_and_hits_the_foothold(controller):
    terrain = Terrain.flat()
    apex = (0.0, 1.0, 2.0)
    batch = controller.leg_angles(apex, [0.6, 0.7], terrain)
    assert controller.leg_angle(apex, 0.7, terrain) == pytest.approx(batch[1])
    assert step(apex, batch[1], terrain).touchdown_x == pytest.approx(0.7, abs=0.005)


def test_bad_inputs(controller):
    terrain = Terrain.flat()
    with pytest.raises(ValueError, match="foothold_x"):
        controller.leg_angle((0, 1, 1), float("nan"), terrain)
    with pytest.raises(ValueError, match="apex.z"):
        controller.leg_angle((0, float("nan"), 1), 0.5, terrain)
    with pytest.raises(ValueError, match="leg_length"):
        controller.check_params(SlipParams(leg_length=0.6))
    controller.check_params(SlipParams(friction=0.6))  # friction does not change the touchdown


def test_save_load_round_trip(controller, tmp_path):
    path = tmp_path / "c.pt"
    controller.save(path)
    again = StepLengthController.load(path)
    np.testing.assert_array_equal(again.leg_angles((0, 1, 2), [0.5, 0.8], Terrain.flat()),
                                  controller.leg_angles((0, 1, 2), [0.5, 0.8], Terrain.flat()))


def test_corrupt_weights_name_the_file(tmp_path):
    bad = tmp_path / "corrupt.pt"
    bad.write_bytes(b"not a torch file")
    with pytest.raises(ValueError, match="corrupt.pt"):
        StepLengthController.load(bad)


def test_mismatched_weights_name_the_file(controller, tmp_path):
    path = tmp_path / "mismatch.pt"
    controller.save(path)
    blob = torch.load(path, weights_only=True)
    blob["config"]["hidden"] = 32  # a config the saved state dict does not fit
    torch.save(blob, path)
    with pytest.raises(ValueError, match="mismatch.pt.*does not match"):
        StepLengthController.load(path)
    torch.save({"format": "something-else"}, path)
    with pytest.raises(ValueError, match="mismatch.pt.*format"):
        StepLengthController.load(path)
