"""The height map families: deterministic per seed, a flat start, each family's ranges, harder with difficulty,
scaled with the hopper's leg, and unknown names refused."""
import numpy as np
import pytest
from scipy import ndimage

from drakeslip.spatial.families import (HEIGHT_MAP_FAMILIES, blocks_map, check_height_map_families, gaps_map,
                                        height_map_family, stairs_map, stones_map)

CELL = 0.05
SEEDS = (0, 1, 2)
DIFFICULTIES = (0.0, 0.5, 1.0)
EPS = 1e-9


def path_row(m):
    """The heights along y = 0."""
    return m.heights[m.index(0.0, 0.0)[0]]


def runs(mask):
    """(first, length) of each run of True in a 1-D mask."""
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return list(zip(starts, ends - starts))


def stones(m):
    """(slices, cell count) of each solid part that is neither the start's ground nor the finish's."""
    labels, _ = ndimage.label(~np.isnan(m.heights), structure=np.ones((3, 3)))
    found = []
    for k, box in enumerate(ndimage.find_objects(labels), 1):
        if box[1].start > 0 and box[1].stop < m.heights.shape[1]:
            found.append((box, int(np.count_nonzero(labels[box] == k))))
    return found


@pytest.mark.parametrize("name", sorted(HEIGHT_MAP_FAMILIES))
def test_a_seed_makes_one_map_and_seeds_differ(name):
    make = HEIGHT_MAP_FAMILIES[name]
    assert np.array_equal(make(3, 0.5).heights, make(3, 0.5).heights, equal_nan=True)
    assert not np.array_equal(make(3, 0.5).heights, make(4, 0.5).heights, equal_nan=True)


@pytest.mark.parametrize("name", sorted(HEIGHT_MAP_FAMILIES))
def test_every_map_starts_flat_and_ends_on_ground(name):
    for seed in SEEDS:
        for difficulty in DIFFICULTIES:
            m = HEIGHT_MAP_FAMILIES[name](seed, difficulty)
            assert m.origin == (-3.0, -3.0) and m.cell == CELL and m.extent == (-3.0, 20.0, -3.0, 3.0)
            start = m.heights[:, :int(round(4.0 / CELL))]   # x < 1 m
            assert np.array_equal(start, np.zeros_like(start)), (name, seed, difficulty)
            assert m.height_at(0.0, 0.0) == 0.0
            assert not np.isnan(m.heights[:, -1]).any(), "the map extends flat past its end: ground, not a hole"


def test_gaps_are_in_range_between_islands_long_enough_at_their_narrowest():
    for seed in SEEDS:
        for difficulty in DIFFICULTIES:
            m = gaps_map(seed, difficulty)
            assert set(np.unique(m.heights[~np.isnan(m.heights)])) == {0.0}
            gaps = runs(np.isnan(path_row(m)))
            assert gaps, (seed, difficulty)
            assert all(0.1 - CELL - EPS <= n * CELL <= 1.0 + CELL + EPS for _, n in gaps), gaps
            for row in m.heights:   # every gap crosses the whole map, islands at least 0.4 m in every row
                assert len(runs(np.isnan(row))) == len(gaps)
                islands = runs(~np.isnan(row))[1:-1]
                assert all(n * CELL >= 0.4 - CELL - EPS for _, n in islands), islands


def test_stones_are_in_range_over_a_hole_and_reachable_one_from_the_next():
    for seed in SEEDS:
        for difficulty in DIFFICULTIES:
            m = stones_map(seed, difficulty)
            found = stones(m)
            assert len(found) >= 10, (seed, difficulty)
            spans = []
            for (rows, cols), count in found:
                sizes = ((rows.stop - rows.start) * CELL, (cols.stop - cols.start) * CELL)
                assert all(0.15 - EPS <= s <= 0.6 + EPS for s in sizes), sizes
                assert count == (rows.stop - rows.start) * (cols.stop - cols.start), "a stone is one block"
                height = np.unique(m.heights[rows, cols])
                assert height.size == 1 and abs(height[0]) <= 0.15 + EPS
                spans.append((-3.0 + cols.start * CELL, -3.0 + cols.stop * CELL))
            finish = -3.0 + (m.heights.shape[1] - runs(~np.isnan(path_row(m)))[-1][1]) * CELL
            reached, todo = set(), [1.0]   # the start's ground ends at x = 1 m; a hop reaches 0.6 m on
            while todo:
                edge = todo.pop()
                ahead = {end for begin, end in spans if edge - EPS < begin <= edge + 0.6 + EPS} - reached
                reached |= ahead
                todo += ahead
            assert max(reached) >= finish - 0.6 - EPS, f"seed {seed}, difficulty {difficulty}: stones end short"


def test_stairs_change_level_by_a_rise_in_range():
    for seed in SEEDS:
        for difficulty in DIFFICULTIES:
            h = stairs_map(seed, difficulty).heights
            assert not np.isnan(h).any() and -0.3 - EPS <= h.min() and h.max() <= 0.5 + EPS
            changes = np.abs(np.concatenate((np.diff(h, axis=0).ravel(), np.diff(h, axis=1).ravel())))
            changes = changes[changes > EPS]
            assert changes.size and changes.min() >= 0.05 - EPS and changes.max() <= 0.25 + EPS, (seed, difficulty)


def test_blocks_stand_on_the_path_and_aside():
    for seed in SEEDS:
        for difficulty in DIFFICULTIES:
            m = blocks_map(seed, difficulty)
            heights = np.unique(m.heights)
            assert heights[0] == 0.0 and heights[1] >= 0.05 - EPS and heights[-1] <= 0.25 + EPS
            labels, count = ndimage.label(m.heights > 0)
            on_path = set(np.unique(labels[m.index(0.0, 0.0)[0]])) - {0}
            assert on_path and len(on_path) < count, (seed, difficulty)


def test_a_course_keeps_every_step_between_solid_cells_within_a_rise():
    kinds = set()
    for seed in SEEDS:
        for difficulty in DIFFICULTIES:
            h = HEIGHT_MAP_FAMILIES["course"](seed, difficulty).heights
            for step in (np.diff(h, axis=0), np.diff(h, axis=1)):
                assert np.nanmax(np.abs(step)) <= 0.25 + EPS
            kinds |= {"holes"} if np.isnan(h).any() else set()
            kinds |= {"levels"} if np.nanmax(np.abs(h)) > 0 else set()
    assert kinds == {"holes", "levels"}


def mean_size(name, difficulty):
    """The mean of what makes a map of ``name`` hard, over seeds: gap width, stone size, rise, block height."""
    found = []
    for seed in range(8):
        m = HEIGHT_MAP_FAMILIES[name](seed, difficulty)
        if name == "gaps":
            found += [n * CELL for _, n in runs(np.isnan(path_row(m)))]
        elif name == "stones":
            found += [(box[1].stop - box[1].start) * CELL for box, _ in stones(m)]
        elif name == "stairs":
            steps = np.abs(np.diff(path_row(m)))
            found += list(steps[steps > EPS])
        else:
            found += list(np.unique(m.heights[m.heights > 0]))
    return np.mean(found)


def test_difficulty_one_is_harder_than_zero():
    assert mean_size("gaps", 1.0) > mean_size("gaps", 0.0) + 0.3
    assert mean_size("stones", 1.0) < mean_size("stones", 0.0) - 0.15
    assert mean_size("stairs", 1.0) > mean_size("stairs", 0.0) + 0.07
    assert mean_size("blocks", 1.0) > mean_size("blocks", 0.0) + 0.07


@pytest.mark.parametrize("name", sorted(HEIGHT_MAP_FAMILIES))
def test_a_longer_leg_scales_the_map(name):
    small, large = HEIGHT_MAP_FAMILIES[name](5, 0.7), HEIGHT_MAP_FAMILIES[name](5, 0.7, length=2.0)
    assert np.array_equal(large.heights, 2.0 * small.heights, equal_nan=True)
    assert large.cell == 2 * small.cell and large.origin == (-6.0, -6.0)


def test_unknown_families_and_difficulties_are_refused():
    assert check_height_map_families(["gaps", "course"]) == ("gaps", "course")
    assert height_map_family("stones") is stones_map
    with pytest.raises(ValueError, match=r"unknown height map families \['hills'\].*'stairs'"):
        check_height_map_families(["gaps", "hills"])
    with pytest.raises(ValueError, match="hills"):
        height_map_family("hills")
    with pytest.raises(ValueError, match="unknown height map families"):
        check_height_map_families([])
    with pytest.raises(ValueError, match="difficulty"):
        gaps_map(0, 1.5)
    with pytest.raises(ValueError, match="length"):
        gaps_map(0, 0.5, length=0.0)
