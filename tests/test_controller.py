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
    with pytest.raises(TypeError, match="SlipParams"):
        controller.for_params({"leg_length": 0.6})


def random_hoppers(rng, n):
    """Hoppers across the range the toolkit is for: 3-30 kg, legs of 0.3-1.2 m, k L0 / (m g) of 10-40, friction
    0.6-1.0, on the Earth and on a lighter planet."""
    hoppers = []
    for _ in range(n):
        mass, leg, kd = rng.uniform(3, 30), rng.uniform(0.3, 1.2), rng.uniform(10, 40)
        gravity = rng.choice([9.81, 3.7])
        hoppers.append(SlipParams(mass=mass, leg_length=leg, stiffness=kd * mass * gravity / leg, gravity=gravity,
                                  friction=rng.uniform(0.6, 1.0)))
    return hoppers


@pytest.mark.parametrize("terrain_kind", ["flat", "step-down"])
def test_scaled_angles_land_on_their_footholds_for_any_hopper(controller, terrain_kind):
    """The network fed a hopper's features in the trained hopper's units, polished with the hopper's L0 and g,
    lands that hopper's foot on its footholds as accurately as the trained hopper's."""
    rng = np.random.default_rng(7)
    for params in random_hoppers(rng, 6):
        scale = params.leg_length / 0.5
        heights = np.zeros(200) if terrain_kind == "flat" else np.r_[np.zeros(66), np.full(134, -0.2 * scale)]
        terrain = Terrain(heights, cell=0.05 * scale, x0=-3.0 * scale)
        mine = controller.for_params(params)
        assert mine is controller.for_params(params) and mine.feature_scale is not None
        speed = np.sqrt(params.gravity * params.leg_length / (9.81 * 0.5))
        apex = np.stack([rng.uniform(-0.5, 0.5, 800) * scale, rng.uniform(0.7, 1.2, 800) * scale,
                         rng.uniform(0.5, 3.0, 800) * speed], 1)
        res = step_batch(apex, rng.uniform(-0.5, 0.6, 800), terrain, params)
        touched = np.isfinite(res.touchdown_x)   # the flight reached the ground (the stance may still fail)
        apex, target = apex[touched], res.touchdown_x[touched]
        landed = step_batch(apex, mine.leg_angles(apex, target, terrain), terrain, params).touchdown_x
        err = np.abs(landed - target) / scale
        assert target.size > 300 and np.quantile(err, 0.9) < 1e-9 and err.max() < 1e-6
        unpolished = np.abs(step_batch(apex, mine.leg_angles(apex, target, terrain, refine=False), terrain,
                                       params).touchdown_x - target) / scale
        assert np.median(unpolished) < 0.002   # the network alone: a millimetre in the trained hopper's units


def test_the_trained_hoppers_angles_are_bit_identical(controller):
    """For the hopper it was trained for (any mass, stiffness or friction: only L0 and g matter) the controller
    is itself, unscaled; a hopper with another L0 gets a view that shares the network."""
    for params in (SlipParams(), SlipParams(mass=12.0, stiffness=9000.0, friction=0.6)):
        assert controller.for_params(params) is controller
    apex, footholds = (0.0, 1.0, 2.0), np.linspace(0.3, 0.9, 25)
    reference = StepLengthController.load_default()
    np.testing.assert_array_equal(controller.for_params(SlipParams()).leg_angles(apex, footholds, Terrain.flat()),
                                  reference.leg_angles(apex, footholds, Terrain.flat()))
    other = controller.for_params(SlipParams(leg_length=0.7))
    assert other is not controller and other.weights().keys() == controller.weights().keys()
    assert other.for_params(SlipParams()) is controller


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
