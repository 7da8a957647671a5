"""The spatial SLIP: its compiled step map is the planar one without lateral motion, turns with the world, agrees with
the Drake SlipHopper3D; height maps refuse bad input; the controller lands where it aims."""
import math

import numpy as np
import pytest

import drakeslip as ds
from drakeslip import fast_step as planar
from drakeslip.spatial import fast_step as spatial
from drakeslip.spatial.controller import aim_many, leg_angles_for
from drakeslip.spatial.dynamics import leg_offset
from drakeslip.spatial.families import height_map_family
from drakeslip.spatial.heightmap import HeightMap, load_height_map
from drakeslip.spatial.simulation import simulate3d
from drakeslip.spatial.stepmap import step3d, step_batch3d
from verification.backend_agreement3d import compare_backends3d

P = ds.SlipParams()
STANCE_STEPS = np.int64(60)


def planar_hops(terrain, n, seed):
    """Random planar hops over ``terrain``: apexes (n, 3) and leg angles (n,)."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1.0, 10.0, n)
    z = np.maximum(terrain.height_at(x) + rng.uniform(0.45, 1.1, n), 0.5)
    return np.column_stack([x, z, rng.uniform(0.3, 3.0, n)]), rng.uniform(-0.6, 0.6, n)


@pytest.mark.parametrize("family", ["ditch", "step", "mixed"])
def test_without_lateral_motion_a_hop_is_the_planar_hop(family):
    """On a planar terrain extruded across the path, with y-velocity 0 and roll 0, every outcome and number of the
    compiled spatial map equals the planar map's (the same arithmetic); y stays where it was up to one rounding."""
    terrain = ds.TERRAIN_FAMILIES[family](11)
    apexes, angles = planar_hops(terrain, 600, seed=1)
    y = np.random.default_rng(2).uniform(-1.0, 1.0, apexes.shape[0])
    rows = np.column_stack([apexes[:, 0], y, apexes[:, 1], apexes[:, 2], np.zeros(len(y))])
    flat = planar.step_many(apexes[:, 0].copy(), apexes[:, 1].copy(), apexes[:, 2].copy(), angles, P.as_array(),
                            terrain.ground(), STANCE_STEPS)
    space = spatial.step_many(rows, np.column_stack([angles, np.zeros(len(y))]), P.as_array(),
                              HeightMap.from_profile(terrain, -3.0, 3.0).ground(), STANCE_STEPS)
    assert np.array_equal(flat[:, planar.OUT_CODE], space[:, spatial.OUT_CODE])
    assert len(set(flat[:, planar.OUT_CODE].astype(int))) >= 4   # several outcomes: the test means something
    pairs = [(planar.OUT_TD_X, spatial.OUT_TD_X), (planar.OUT_X, spatial.OUT_X), (planar.OUT_Z, spatial.OUT_Z),
             (planar.OUT_XDOT, spatial.OUT_XDOT), (planar.OUT_ZDOT, spatial.OUT_ZDOT), (planar.OUT_TIME, spatial.OUT_TIME)]
    for a, b in pairs:
        assert np.array_equal(flat[:, a], space[:, b], equal_nan=True)
    ok = space[:, spatial.OUT_CODE] == 0
    assert np.allclose(space[ok, spatial.OUT_Y], y[ok], rtol=0, atol=1e-15)
    assert np.all(space[ok, spatial.OUT_YDOT] == 0.0)


def test_without_lateral_motion_the_drake_hopper_is_the_planar_one():
    terrain = ds.step_world(5)
    height_map = HeightMap.from_profile(terrain, -3.0, 3.0)
    for (x, z, v), angle in zip(*planar_hops(terrain, 6, seed=3)):
        flat = ds.step((x, z, v), angle, terrain, P, backend="drake")
        space = step3d((x, 0.3, z, v, 0.0), (angle, 0.0), height_map, P, backend="drake")
        assert flat.failure == space.failure
        if flat.ok:
            assert abs(flat.touchdown_x - space.foothold[0]) < 1e-6
            assert np.allclose(flat.next_apex, np.array(space.next_apex)[[0, 2, 3]], atol=1e-6)
            assert abs(space.next_apex.y - 0.3) < 1e-9 and space.next_apex.ydot == 0.0


def turned(x, y, quarter_turns=0, angle=None):
    a = quarter_turns * math.pi / 2 if angle is None else angle
    c, s = (round(math.cos(a)), round(math.sin(a))) if angle is None else (math.cos(a), math.sin(a))
    return c * x - s * y, s * x + c * y


def turned_legs(angles, **turn):
    """The (pitch, roll) whose foot offset is the given ones' turned."""
    off = np.array([leg_offset(a, b, P.as_array()) for a, b in angles]) / P.leg_length
    ox, oy = turned(off[:, 0], off[:, 1], **turn)
    return np.column_stack([np.arctan2(ox, -off[:, 2]), np.arcsin(np.clip(oy, -1, 1))])


def spatial_hops(height_map, n, seed):
    rng = np.random.default_rng(seed)
    x, y = rng.uniform(0.0, 9.0, n), rng.uniform(-1.5, 1.5, n)
    z = np.nan_to_num(height_map.height_at(x, y), nan=0.0) + rng.uniform(0.5, 1.0, n)
    speed, heading = rng.uniform(0.3, 3.0, n), rng.uniform(-0.6, 0.6, n)
    rows = np.column_stack([x, y, z, speed * np.cos(heading), speed * np.sin(heading)])
    tilt, azimuth = rng.uniform(0, 0.6, n), heading + rng.uniform(-1.0, 1.0, n)
    u = np.column_stack([np.sin(tilt) * np.cos(azimuth), np.sin(tilt) * np.sin(azimuth), -np.cos(tilt)])
    return rows, np.column_stack([np.arctan2(u[:, 0], -u[:, 2]), np.arcsin(u[:, 1])])


def rotated_rows(rows, **turn):
    out = rows.copy()
    out[:, 0], out[:, 1] = turned(rows[:, 0], rows[:, 1], **turn)
    out[:, 3], out[:, 4] = turned(rows[:, 3], rows[:, 4], **turn)
    return out


def check_turned(before, after, **turn):
    assert np.array_equal(before[:, spatial.OUT_CODE], after[:, spatial.OUT_CODE])
    ok = before[:, spatial.OUT_CODE] == 0
    for (cx, cy) in ((spatial.OUT_TD_X, spatial.OUT_TD_Y), (spatial.OUT_X, spatial.OUT_Y),
                     (spatial.OUT_XDOT, spatial.OUT_YDOT)):
        tx, ty = turned(before[ok, cx], before[ok, cy], **turn)
        assert np.allclose(after[ok, cx], tx, atol=1e-9) and np.allclose(after[ok, cy], ty, atol=1e-9)
    assert np.allclose(after[ok, spatial.OUT_Z], before[ok, spatial.OUT_Z], atol=1e-9)
    return int(ok.sum())


@pytest.mark.parametrize("family", ["gaps", "stones", "stairs", "blocks", "course"])
def test_turning_the_world_by_quarter_turns_turns_every_hop(family):
    """The map's grid turns onto itself by quarter turns about the vertical: the same outcomes, and footholds,
    apexes and velocities turned, to rounding."""
    height_map = height_map_family(family)(7, 0.5)
    rows, angles = spatial_hops(height_map, 400, seed=4)
    before = spatial.step_many(rows, angles, P.as_array(), height_map.ground(), STANCE_STEPS)
    landed = 0
    for k in (1, 2, 3):
        after = spatial.step_many(rotated_rows(rows, quarter_turns=k), turned_legs(angles, quarter_turns=k),
                                  P.as_array(), height_map.rotated90(k).ground(), STANCE_STEPS)
        landed = check_turned(before, after, quarter_turns=k)
    assert landed >= 10


@pytest.mark.parametrize("angle", [0.3, 1.9, -2.6])
def test_turning_the_world_by_any_angle_turns_every_hop_on_flat_ground(angle):
    flat = HeightMap.flat(0.0, 0.05, (-40.0, -40.0), (80.0, 80.0))
    rows, angles = spatial_hops(flat, 300, seed=5)
    before = spatial.step_many(rows, angles, P.as_array(), flat.ground(), STANCE_STEPS)
    after = spatial.step_many(rotated_rows(rows, angle=angle), turned_legs(angles, angle=angle), P.as_array(),
                              flat.ground(), STANCE_STEPS)
    assert check_turned(before, after, angle=angle) >= 30


def test_the_drake_hopper_turns_with_the_world():
    flat = HeightMap.flat(0.0, 0.05, (-10.0, -10.0), (20.0, 20.0))
    apex, leg = (0.5, -0.2, 0.9, 1.4, 0.5), (0.2, 0.05)
    before = step3d(apex, leg, flat, P, backend="drake")
    rows = rotated_rows(np.array([apex]), angle=0.8)
    after = step3d(tuple(rows[0]), tuple(turned_legs([leg], angle=0.8)[0]), flat, P, backend="drake")
    assert before.ok and after.ok
    assert np.allclose(turned(before.next_apex.x, before.next_apex.y, angle=0.8), after.next_apex[:2], atol=1e-6)
    assert abs(before.next_apex.z - after.next_apex.z) < 1e-6


def test_the_backends_agree_on_every_family():
    """A sample of the issue's check (``examples/backend_agreement.py --families gaps --cases 1000`` runs it whole):
    the same outcome, and where both land in the same cell, footholds and apexes within 1e-6 m."""
    report = compare_backends3d(40, seed=9, families=("gaps", "stones", "stairs", "blocks", "course"))
    assert report.disagreement_rate <= 0.05, report.format()
    assert len(report.both_ok) >= 8, report.format()
    assert report.worst_apex_deviation <= 1e-6 and report.worst_touchdown_deviation <= 1e-6, report.format()


def test_a_simulation_runs_several_hops_and_logs_them():
    flat = HeightMap.flat()

    def neutral(apex, hop):   # aim 0.36 s of flight ahead: about where the hop keeps its speed
        return leg_angles_for(apex, (apex.x + 0.36 * apex.xdot, apex.y + 0.36 * apex.ydot, 0.0), P)

    run = simulate3d((0.0, 0.0, 0.9, 1.5, 0.2), neutral, flat, P, max_hops=4)
    assert run.ok and len(run.apexes) == 4 and len(run.footholds) == 4
    assert run.states.shape[1] == 6 and run.hybrid.shape[1] == 11 and len(run.leg_angles) == 4
    assert all(abs(a.ydot / a.xdot - 0.2 / 1.5) < 0.05 for a in run.apexes)   # no turn was asked for
    steady = simulate3d((0.0, 0.0, 0.9, 1.5, 0.2), run.leg_angles[:2], flat, P)
    assert steady.apexes == run.apexes[:2]   # a list of commands flies the same hops


def test_the_controller_lands_on_its_target():
    flat = HeightMap.flat(0.0, 0.05, (-5.0, -5.0), (20.0, 10.0))
    rng = np.random.default_rng(6)
    n = 300
    speed, heading = rng.uniform(0.3, 3.0, n), rng.uniform(-1, 1, n)
    rows = np.column_stack([np.zeros(n), np.zeros(n), rng.uniform(0.6, 1.1, n), speed * np.cos(heading),
                            speed * np.sin(heading)])
    fall = np.sqrt(2 * (rows[:, 2] - P.leg_length) / P.gravity)
    targets = np.column_stack([rows[:, 3] * fall + rng.uniform(-0.2, 0.2, n),
                               rows[:, 4] * fall + rng.uniform(-0.2, 0.2, n), np.zeros(n)])
    aims = aim_many(rows, targets, P.as_array())
    reach = aims[:, 2] < 1e-9
    assert reach.mean() > 0.9
    hops = step_batch3d(rows[reach], aims[reach, :2], flat, P.with_friction(10.0))
    assert np.all(np.isfinite(hops.foothold[:, 0]))
    assert np.max(np.hypot(*(hops.foothold[:, :2] - targets[reach, :2]).T)) < 1e-9
    with pytest.raises(ValueError, match="not below the reach"):
        leg_angles_for((0.0, 0.0, 0.9, 1.0, 0.0), (0.5, 0.0, 2.0), P)


@pytest.mark.parametrize("heights, cell, origin, message", [
    (np.zeros(5), 0.1, (0, 0), "2-D"),
    (np.zeros((0, 3)), 0.1, (0, 0), "2-D"),
    (np.full((3, 3), np.nan), 0.1, (0, 0), "no solid cell"),
    ([[0.0, np.inf]], 0.1, (0, 0), r"heights\[0, 1\]"),
    ([[0.0, "a"]], 0.1, (0, 0), "numbers"),
    (np.zeros((2, 2)), 0.0, (0, 0), "cell"),
    (np.zeros((2, 2)), 1e9, (0, 0), "cell"),
    (np.zeros((2, 2)), 0.1, (np.nan, 0), "origin x0"),
    (np.zeros((2, 2)), 0.1, (0,), "origin"),
])
def test_bad_height_maps_are_refused_in_one_line(heights, cell, origin, message):
    with pytest.raises(ValueError, match=message) as error:
        HeightMap(heights, cell, origin)
    assert "\n" not in str(error.value)


def test_a_map_of_too_many_cells_is_refused_before_it_is_read(tmp_path):
    huge = np.lib.stride_tricks.as_strided(np.zeros(1), shape=(10_000, 10_000), strides=(0, 0))   # 10^8 cells
    with pytest.raises(ValueError, match="more than the 4000000"):
        HeightMap(huge)
    path = tmp_path / "huge.npz"
    np.savez_compressed(path, heights=np.zeros((2100, 2000), dtype=np.float64), cell=0.1, origin=np.zeros(2))
    with pytest.raises(ValueError, match="more than the 4000000 cells"):
        load_height_map(path)


def test_height_map_files(tmp_path):
    heights = np.zeros((20, 30))
    heights[:, 10:13] = np.nan
    saved = HeightMap(heights, 0.1, (-1.0, -1.0))
    saved.save(tmp_path / "map.npz")
    loaded = load_height_map(tmp_path / "map.npz")
    assert np.array_equal(loaded.heights, saved.heights, equal_nan=True)
    assert loaded.cell == 0.1 and loaded.origin == (-1.0, -1.0)
    (tmp_path / "dem.asc").write_text("ncols 3\nnrows 2\nxllcorner 5\nyllcorner 7\ncellsize 0.5\nNODATA_value -9999\n"
                                      "1 2 3\n4 -9999 6\n")
    dem = load_height_map(tmp_path / "dem.asc")
    assert dem.origin == (5.0, 7.0) and dem.height_at(5.1, 7.1) == 4.0 and dem.height_at(5.1, 7.6) == 1.0
    assert dem.is_hole_at(5.6, 7.1)
    np.savez(tmp_path / "bad.npz", heights=np.zeros((2, 2)), cell=0.1)
    for path, message in ((tmp_path / "bad.npz", "lacks origin"), (tmp_path / "none.npz", "cannot be read")):
        with pytest.raises(ValueError, match=message):
            load_height_map(path)
    (tmp_path / "short.asc").write_text("ncols 3\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2 3\n")
    with pytest.raises(ValueError, match="expected 2 rows of 3"):
        load_height_map(tmp_path / "short.asc")
    (tmp_path / "twice.asc").write_text("ncols 3\nnrows 1\nncols 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2\n")
    with pytest.raises(ValueError, match="header line 'ncols' is given twice"):
        load_height_map(tmp_path / "twice.asc")


def test_a_perception_window_is_the_map_over_its_cells():
    height_map = height_map_family("stairs")(2, 0.5)
    window = height_map.perceived(1.0, 0.2, (1.0, 0.0), 8.0, 2.0, 3.0)
    assert not window.extends_flat
    x_min, x_max, y_min, y_max = window.extent
    assert x_min <= -2.0 and x_max >= 9.0 and y_min <= -1.8 and y_max >= 2.2
    xs, ys = np.meshgrid(np.arange(-1.975, 8.9, 0.05), np.arange(-1.725, 2.1, 0.05))   # cell centres
    assert np.array_equal(window.height_at(xs, ys), height_map.height_at(xs, ys), equal_nan=True)
    assert not window.contains(x_max + 0.1, 0.0) and window.contains(0.0, 0.0)
