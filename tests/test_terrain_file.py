"""Terrain files: profiles and heights per cell read onto cells, gaps become ditches (and nothing else does), a
saved terrain reads back equal, and a malformed file is one error naming the file and the line."""
import argparse

import numpy as np
import pytest

import drakeslip as ds
from drakeslip.terrain import DITCH_HEIGHT
from drakeslip.terrain_file import (DITCH_DEPTH, load_terrain, save_terrain, scaled_terrain, terrain_argument,
                                    terrain_with_gaps)


def same(a: ds.Terrain, b: ds.Terrain) -> bool:
    return (a.x0, a.cell, a.ditch_height) == (b.x0, b.cell, b.ditch_height) and np.array_equal(a.heights, b.heights)


def write(tmp_path, text, name="t.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_a_profile_with_gaps_makes_ditches_at_the_papers_height(tmp_path):
    path = write(tmp_path, "x,height\n0,0\n0.5,\n0.8,0.1\n1.2,-inf\n1.4,nan\n1.6,0.3\n")
    terrain = load_terrain(path, cell=0.1)
    assert (terrain.x0, terrain.cell, terrain.ditch_height) == (0.0, 0.1, DITCH_HEIGHT)
    expected = [0.0] * 5 + [DITCH_HEIGHT] * 3 + [0.1] * 4 + [DITCH_HEIGHT] * 4 + [0.3]
    np.testing.assert_array_equal(terrain.heights, expected)
    for x, ditch in [(0.45, False), (0.55, True), (0.79, True), (0.85, False), (1.3, True), (1.55, True),
                     (1.65, False), (5.0, False)]:
        assert terrain.is_ditch_at(x) == ditch, x


def test_without_a_cell_the_grid_is_the_comment_or_the_smallest_spacing(tmp_path):
    rows = "0,0\n0.3,-0.2\n0.5,\n0.6,0.1\n"
    assert load_terrain(write(tmp_path, rows)).cell == 0.1                       # 0.6 - 0.5, rounded
    assert load_terrain(write(tmp_path, "# cell: 0.05\n" + rows)).cell == 0.05
    assert load_terrain(write(tmp_path, "# cell: 0.05\n" + rows), cell=0.02).cell == 0.02


def test_rows_off_the_grid_keep_every_gap_and_the_highest_level(tmp_path):
    # cell 0.2 from x=0: [0.2, 0.4) holds 0 and 0.5; [0.4, 0.6) holds 0.5 and a gap; [0.6, 0.8) holds the gap
    # and 0.2
    terrain = load_terrain(write(tmp_path, "0,0\n0.3,0.5\n0.45,\n0.65,0.2\n"), cell=0.2)
    np.testing.assert_array_equal(terrain.heights, [0.0, 0.5, DITCH_HEIGHT, DITCH_HEIGHT, 0.2])


def test_ground_below_the_papers_ditch_height_stays_solid(tmp_path):
    terrain = load_terrain(write(tmp_path, "0,0\n1,-1.5\n2,\n3,-2\n"), cell=0.5)
    assert terrain.ditch_height == -2.0 - DITCH_DEPTH
    assert not terrain.is_ditch_at(1.2) and not terrain.is_ditch_at(3.2) and terrain.is_ditch_at(2.2)
    assert terrain.height_at(1.2) == -1.5 and terrain.height_at(2.2) == terrain.ditch_height


def test_heights_per_cell_read_with_every_way_of_writing_a_gap(tmp_path):
    path = write(tmp_path, "# my ridge\n# cell: 0.25, x0: -1\n0\n0, 0.2,,0.2\n-inf\nNaN\n\n0.4 \n", "t.txt")
    terrain = load_terrain(path)
    assert (terrain.x0, terrain.cell) == (-1.0, 0.25)
    np.testing.assert_array_equal(terrain.heights, [0, 0, 0.2, -1, 0.2, -1, -1, 0.4])
    assert [terrain.is_ditch_at(-1 + 0.25 * i + 0.1) for i in range(8)] == [False] * 3 + [True, False] + \
        [True, True, False]
    spaced = load_terrain(write(tmp_path, "# cell: 0.25, x0: -1\n0 0 0.2 nan 0.2\n", "s.txt"))
    np.testing.assert_array_equal(spaced.heights, [0, 0, 0.2, -1, 0.2])


def round_trip(terrain, tmp_path):
    save_terrain(terrain, tmp_path / "t.csv")
    return load_terrain(tmp_path / "t.csv")


@pytest.mark.parametrize("make", [lambda: ds.ditch_world(1000), lambda: ds.step_world(2000),
                                  lambda: ds.mixed_world(3000)])
def test_generated_terrains_round_trip_equal(tmp_path, make):
    terrain = make()
    assert same(round_trip(terrain, tmp_path), terrain)
    assert same(scaled_terrain(terrain, 1.0), terrain)


def test_a_terrain_file_with_gaps_round_trips_equal(tmp_path):
    for text in ("x,height\n0.0,0.1\n0.3,\n0.5,0.2\n0.55,-inf\n0.6,0\n",
                 "# cell: 0.07, x0: -0.35\n-1.2\n-1.2\n\n-1.3\n-inf\n-0.9\n"):
        terrain = load_terrain(write(tmp_path, text, "in.csv"))
        again = round_trip(terrain, tmp_path)
        assert same(again, terrain)
        gaps = terrain.heights <= terrain.ditch_height
        assert gaps.any() and all(again.is_ditch_at(terrain.x0 + (i + 0.5) * terrain.cell) == g
                                  for i, g in enumerate(gaps))


def test_a_saved_terrain_keeps_its_ditches_when_their_floor_moves(tmp_path):
    terrain = ds.Terrain([0.0, -3.0, -3.0, 0.2], cell=0.1, x0=0.0, ditch_height=-2.0)
    again = round_trip(terrain, tmp_path)
    np.testing.assert_array_equal(again.heights, [0.0, DITCH_HEIGHT, DITCH_HEIGHT, 0.2])
    assert [again.is_ditch_at(x) for x in (0.05, 0.15, 0.25, 0.35)] == [False, True, True, False]


def test_a_scaled_terrain_is_the_same_ground_in_longer_units():
    terrain = ds.mixed_world(3000)
    big = scaled_terrain(terrain, 1.4)
    assert (big.cell, big.x0) == pytest.approx((0.14, -4.2))
    solid = terrain.heights > terrain.ditch_height
    np.testing.assert_allclose(big.heights[solid], 1.4 * terrain.heights[solid])
    np.testing.assert_array_equal(big.heights <= big.ditch_height, ~solid)
    deep = scaled_terrain(ds.step_world(2000), 4.0)          # levels down to -1.2 m: solid, not ditches
    assert not (deep.heights <= deep.ditch_height).any()


@pytest.mark.parametrize("text, what", [
    ("x,height\n0,0\n0.1,abc\n", "line 3: height 'abc' is not a number"),
    ("0,0\n0.1,inf\n", "line 2: height 'inf' is not finite"),
    ("0,0\n0.2,0\n\n0.2,0.1\n", "line 4: x=0.2 does not follow x=0.2"),
    ("0,0\n# note\n0.1,0,0\n", "line 3: a profile row is 'x,height', got 3 field"),
    ("0,0\nnan,0\n", "line 2: x must be a number in \\[-10000, 10000\\] m, got 'nan'"),
    ("x,height\ny,z\n", "line 2: x must be a number in \\[-10000, 10000\\] m, got 'y'"),
    ("# cell: -0.1\n0,0\n0.1,0\n", "line 1: cell must be a number in \\[0.001, 10\\] m, got '-0.1'"),
    ("# cell: 0.1\n# cell: 0.2\n0,0\n", "line 2: cell is given twice \\(also on line 1\\)"),
    ("# x0: 0\n0\n0\n", "line 1: heights per cell need the cell size too"),
    ("# cell: 0.1, x0: 0\n0\n0,zero\n", "line 3: height 'zero' is not a number"),
    ("# cell: 0.1, x0: 0\n-inf\n,\n", "no solid cell"),
    ("# only comments\n\n", "has no rows of heights"),
    ("0,1\n", "a one-row profile needs the cell size"),
])
def test_a_malformed_file_is_one_line_naming_the_file_and_row(tmp_path, text, what):
    path = write(tmp_path, text)
    with pytest.raises(ValueError, match=what) as error:
        load_terrain(path)
    assert str(error.value).startswith(f"terrain file {path}") and "\n" not in str(error.value)


def test_gaps_need_ground_somewhere():
    with pytest.raises(ValueError, match="at least one solid cell"):
        terrain_with_gaps([np.nan, -np.inf], 0.1, 0.0)


def test_the_argument_type_is_one_line(tmp_path):
    assert same(terrain_argument(str(write(tmp_path, "0,0\n0.1,\n0.2,0\n"))), load_terrain(tmp_path / "t.csv"))
    with pytest.raises(argparse.ArgumentTypeError, match="no such terrain file"):
        terrain_argument(str(tmp_path / "missing.csv"))
    with pytest.raises(argparse.ArgumentTypeError, match=r"t.csv, line 1: height 'h' is not a number"):
        terrain_argument(str(write(tmp_path, "0,h\n")))


def test_resampling_keeps_the_highest_height_and_every_gap_of_the_rows_over_a_cell():
    """The resampling, at once over every cell, against the rule written out cell by cell."""
    import numpy as np

    from drakeslip.terrain_file import OVERLAP_TOLERANCE, resample

    rng = np.random.default_rng(0)
    for _ in range(50):
        xs = np.cumsum(rng.uniform(0.01, 0.3, 40))
        heights = np.where(rng.random(40) < 0.2, np.nan, rng.normal(0, 0.1, 40))
        cell = rng.uniform(0.02, 0.5)
        x_end = xs[-1] + cell
        got = resample(xs, heights, x_end, cell)
        for j, value in enumerate(got):
            lo, hi = xs[0] + j * cell, xs[0] + (j + 1) * cell
            over = [h for i, h in enumerate(heights) if xs[i] < hi - OVERLAP_TOLERANCE * cell
                    and (i + 1 == len(xs) or xs[i + 1] > lo + OVERLAP_TOLERANCE * cell)]
            expected = np.nan if any(np.isnan(over)) else max(over)
            assert value == expected or (np.isnan(value) and np.isnan(expected)), (j, value, expected)


def test_rows_1_mm_apart_far_from_zero_make_1_mm_cells(tmp_path):
    """x = 9990.000, 9990.001, ...: their differences are off by float rounding (0.000999999998), not their cells."""
    rows = "".join(f"{9990 + k * 0.001:.3f},{0.02 if k < 500 else 0}\n" for k in range(1001))
    terrain = load_terrain(write(tmp_path, rows))
    assert (terrain.cell, terrain.x0, terrain.heights.size) == (0.001, 9990.0, 1001)
    assert terrain.height_at(9990.25) == 0.02 and terrain.height_at(9990.75) == 0.0
