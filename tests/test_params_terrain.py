"""Input validation, and the properties promised by the terrain generators."""
import math

import numpy as np
import pytest

import drakeslip as ds

SEEDS = range(40)
CELL = 0.1


def runs(heights):
    """Maximal runs of equal height: (height, first cell, number of cells)."""
    edges = np.flatnonzero(np.diff(heights)) + 1
    starts, ends = np.r_[0, edges], np.r_[edges, heights.size]
    return [(heights[s], s, e - s) for s, e in zip(starts, ends)]


def interior_runs(terrain):
    """Runs after the flat start and before the last (which the terrain's end may cut short)."""
    return runs(terrain.heights)[1:-1]


# ---- validation ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("heights, match", [
    ([0.0, math.nan, 0.0], r"heights\[1\] must be a finite number in \[-10000, 10000\] m, got nan"),
    ([0.0, 0.0, math.inf], r"heights\[2\] must be .*, got inf"),
    ([-math.inf], r"heights\[0\] must be .*, got -inf"),
    ([0.0, 1e308], r"heights\[1\] must be a finite number in \[-10000, 10000\] m, got 1e\+308"),
    ([0.0, 10 ** 400], r"heights\[1\] must be .*, got 1000000000000000\.\.\. \(401 characters\)"),
    ([], r"non-empty.*\(0,\)"),
    ([[0.0, 1.0]], r"1-D.*\(1, 2\)"),
])
def test_terrain_rejects_bad_heights(heights, match):
    with pytest.raises(ValueError, match=match):
        ds.Terrain(heights)


@pytest.mark.parametrize("cell", [0.0, -0.1, math.nan, math.inf])
def test_terrain_rejects_bad_cell(cell):
    with pytest.raises(ValueError, match=f"cell size.*{cell}"):
        ds.Terrain([0.0, 0.1], cell=cell)


def test_terrain_rejects_bad_origin_and_incomplete_dict():
    with pytest.raises(ValueError, match="x0.*nan"):
        ds.Terrain([0.0], x0=math.nan)
    with pytest.raises(ValueError, match="'cell'"):
        ds.Terrain.from_dict({"x0": 0.0, "heights": [0.0]})


@pytest.mark.parametrize("field, value", [
    ("mass", 0.0), ("mass", -7.0), ("leg_length", math.nan), ("stiffness", math.inf), ("gravity", -9.81),
    ("friction", 0.0),
])
def test_params_reject_non_positive_or_non_finite(field, value):
    with pytest.raises(ValueError, match=f"{field}.*{value}"):
        ds.SlipParams(**{field: value})


@pytest.mark.parametrize("field, value", [("mass", True), ("friction", np.bool_(False)), ("stiffness", "3200"),
                                          ("gravity", None)])
def test_params_reject_booleans_and_text(field, value):
    shown = repr(value.item() if isinstance(value, np.generic) else value)
    with pytest.raises(ValueError, match=rf"SlipParams.{field} must be a positive finite number in \[.*, got {shown}"):
        ds.SlipParams(**{field: value})


def test_numpy_scalars_are_numbers_wherever_a_float_is():
    params = ds.SlipParams(mass=np.int64(7), friction=np.float32(0.5), min_leg_length=np.float16(0.25))
    assert params == ds.SlipParams(mass=7.0, friction=float(np.float32(0.5)), min_leg_length=0.25)
    assert all(type(v) is float for v in params.as_array().tolist())
    terrain = ds.Terrain(np.zeros(10), cell=np.float32(0.1), x0=np.int32(-1), ditch_height=np.float64(-1.0))
    assert (terrain.cell, terrain.x0, terrain.ditch_height) == (float(np.float32(0.1)), -1.0, -1.0)
    from planners import Budget

    assert Budget(max_nodes=np.int64(5)).max_nodes == 5


@pytest.mark.parametrize("kwargs, match", [({"ditch_height": math.nan}, "ditch_height must be a finite number"),
                                           ({"ditch_height": True}, "ditch_height must be a finite number"),
                                           ({"cell": True}, r"cell size must be a positive finite number in \[0.001, 10\] m"),
                                           ({"x0": np.bool_(True)}, "x0 must be a finite number")])
def test_terrain_rejects_booleans_and_nan_everywhere(kwargs, match):
    with pytest.raises(ValueError, match=match):
        ds.Terrain([0.0, 0.1], **kwargs)


def test_a_planner_says_when_its_apex_is_inside_a_ditch():
    import planners

    heights = np.zeros(200)
    heights[40:45] = ds.terrain.DITCH_HEIGHT  # a ditch over x in [1.0, 1.5)
    terrain = ds.Terrain(heights)
    for name in ("heuristic", "angle", "step"):
        with pytest.raises(ValueError, match=r"apex \(x=1.2, z=-0.5\) is inside a ditch: its far side at x=1.5"):
            planners.make(name).plan((1.2, -0.5, 2.0), terrain, 10.0)
        with pytest.raises(ValueError, match="not above the terrain"):
            planners.make(name).plan((0.5, -0.1, 2.0), terrain, 10.0)
    assert planners.make("heuristic").plan((1.2, 0.9, 2.0), terrain, 10.0).success  # above the ditch: fine


@pytest.mark.parametrize("min_leg", [0.0, 0.5, 0.7, math.nan])
def test_params_reject_min_leg_outside_the_leg(min_leg):
    with pytest.raises(ValueError, match=f"min_leg_length.*{min_leg}"):
        ds.SlipParams(leg_length=0.5, min_leg_length=min_leg)


def test_params_default_stroke_and_geyer_runner():
    assert ds.SlipParams().min_leg_length == pytest.approx(0.3)
    geyer = ds.SlipParams(mass=80, leg_length=1, stiffness=10.7 * 80 * 9.81)
    assert geyer.min_leg_length == pytest.approx(0.6)
    assert geyer.max_leg_angle == pytest.approx(math.atan(0.8))


@pytest.mark.parametrize("backend", ["fast", "drake"])
@pytest.mark.parametrize("apex, angle, match", [
    ((0.0, -0.1, 1.0), 0.1, r"apex z=-0.1 is not above the terrain"),
    ((0.0, 0.0, 1.0), 0.1, r"apex z=0.0 is not above the terrain"),
    ((math.nan, 0.6, 1.0), 0.1, r"apex.x must be a finite number in \[-10000, 10000\] m, got nan"),
    ((0.0, 0.6, math.inf), 0.1, r"apex.xdot must be a finite number in \[-50, 50\] m/s, got inf"),
    ((0.0, 0.6, 1.0), math.nan, r"leg_angle .* got nan"),
    ((0.0, 0.6, 1.0), math.pi / 2, r"leg_angle .* got 1.57"),
    ((0.0, 0.6, 1.0), -2.0, r"leg_angle .* got -2.0"),
])
def test_step_rejects_bad_inputs(apex, angle, match, backend):
    with pytest.raises(ValueError, match=match):
        ds.step(apex, angle, ds.Terrain.flat(), ds.SlipParams(), backend=backend)


def test_step_rejects_apex_below_a_block_and_unknown_backend():
    block = ds.Terrain(np.r_[np.zeros(30), np.full(10, 0.8)], x0=-3.0)
    with pytest.raises(ValueError, match=r"apex z=0.6 is not above the terrain \(height 0.8 at x=0.5\)"):
        ds.step((0.5, 0.6, 1.0), 0.1, block)
    with pytest.raises(ValueError, match="unknown backend 'ode45'"):
        ds.step((0.0, 0.6, 1.0), 0.1, ds.Terrain.flat(), backend="ode45")


def test_step_batch_rejects_bad_angles_and_shapes():
    flat = ds.Terrain.flat()
    with pytest.raises(ValueError, match="leg angles .* got inf"):
        ds.step_batch((0.0, 0.6, 1.0), [0.1, math.inf], flat)
    with pytest.raises(ValueError, match=r"shape \(2, 3\), got shape \(3, 3\)"):
        ds.step_batch(np.zeros((3, 3)), [0.1, 0.2], flat)
    with pytest.raises(ValueError, match="stance_steps must be at least 4, got 2"):
        ds.step_batch((0.0, 0.6, 1.0), [0.1], flat, stance_steps=2)


# ---- terrain geometry ---------------------------------------------------------------------------------------

def test_height_lookup_and_flat_extension():
    terrain = ds.Terrain([0.0, 0.2, -1.0], cell=0.5, x0=1.0)
    assert terrain.height_at(1.49) == 0.0 and terrain.height_at(1.5) == 0.2
    assert terrain.height_at(-50.0) == 0.0 and terrain.height_at(50.0) == -1.0
    assert terrain.is_ditch_at(2.2) and not terrain.is_ditch_at(1.7)
    np.testing.assert_array_equal(terrain.height_at(np.array([1.2, 1.7, 2.2])), [0.0, 0.2, -1.0])


def test_a_map_without_footholds_before_rises_has_ditches_just_before_each_rise():
    terrain = ds.Terrain([0.0, 0.0, 0.0, 0.1, 0.1, -1.0, 0.1, 0.3, 0.2, 0.2], cell=0.1, x0=0.0, extends_flat=False)
    np.testing.assert_array_equal(terrain.without_footholds_before_rises(0.08).heights,
                                  [0.0, 0.0, -1.0, 0.1, 0.1, -1.0, -1.0, 0.3, 0.2, 0.2])   # a drop stays solid
    np.testing.assert_array_equal(terrain.without_footholds_before_rises(0.15).heights,
                                  [0.0, -1.0, -1.0, 0.1, 0.1, -1.0, -1.0, 0.3, 0.2, 0.2])
    assert terrain.without_footholds_before_rises(0.0) is terrain
    assert not terrain.without_footholds_before_rises(0.08).extends_flat
    with pytest.raises(ValueError, match="keep-out width"):
        terrain.without_footholds_before_rises(float("nan"))


@pytest.mark.parametrize("family", ["ditch", "step", "mixed"])
def test_generators_are_deterministic_and_flat_at_the_start(family):
    make = ds.TERRAIN_FAMILIES[family]
    for seed in SEEDS:
        terrain = make(seed)
        np.testing.assert_array_equal(terrain.heights, make(seed).heights)
        xs = np.arange(terrain.x0, 1.0, 0.01)
        assert np.all(terrain.height_at(xs) == 0.0), (family, seed)
        assert terrain.height_at(1.05) != 0.0  # a step or a ditch starts where the flat start ends
    assert not np.array_equal(make(0).heights, make(1).heights)


def test_ditch_world_properties():
    for seed in SEEDS:
        terrain = ds.ditch_world(seed)
        assert set(np.unique(terrain.heights)) <= {0.0, -1.0}
        assert terrain.height_at(1.05) == -1.0  # the first ditch starts where the flat start ends
        for height, _, n in interior_runs(terrain):
            width = n * CELL
            if height == -1.0:
                assert 0.2 - 1e-9 <= width <= 0.6 + 1e-9, (seed, width)
            else:
                assert 0.4 - 1e-9 <= width <= 1.5 + 1e-9, (seed, width)


def test_step_world_properties():
    for seed in SEEDS:
        terrain = ds.step_world(seed)
        levels = [height for height, _, _ in runs(terrain.heights)]
        assert min(levels) >= -0.3 and max(levels) <= 0.5, seed
        changes = np.abs(np.diff(levels))
        assert np.all((changes >= 0.05 - 1e-4) & (changes <= 0.25 + 1e-4)), (seed, changes)
        for _, _, n in interior_runs(terrain):
            assert 0.6 - CELL - 1e-9 <= n * CELL <= 2.0 + CELL + 1e-9, (seed, n)


@pytest.mark.parametrize("x_body", [-2.5, 0.0, 0.05, 2.349, 7.31, 18.0])
def test_window_is_the_papers_perception_window(x_body):
    terrain = ds.step_world(7)
    heights, x_start = terrain.window(x_body)
    assert heights.shape == (110,)
    cells_from_origin = (x_start - terrain.x0) / terrain.cell
    assert cells_from_origin == pytest.approx(round(cells_from_origin), abs=1e-9)  # on the terrain's grid
    # The body sits in cell 30: 3 m of cells behind it, 8 m from its cell on.
    assert math.floor((x_body - x_start) / terrain.cell + 1e-9) == 30
    centres = x_start + (np.arange(110) + 0.5) * terrain.cell
    np.testing.assert_array_equal(heights, terrain.height_at(centres))
