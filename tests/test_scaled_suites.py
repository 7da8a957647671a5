"""Suites drawn for a hopper are the paper's problems in its units (for the paper's hopper, the committed suites
themselves), suites from terrain files pair every profile with every start, and both record their hopper."""
import json
import math
from pathlib import Path

import numpy as np
import pytest

from drakeslip import SlipParams
from drakeslip.hopper_file import NamedHopper, paper_hopper
from planners.formats.suite import load_suite, make_suite, save_suite
from planners.formats.suite_draw import draw_suite, suite_from_terrains, suite_hopper, suite_scales

ROOT = Path(__file__).resolve().parents[1]
BIG = NamedHopper(SlipParams(mass=12.0, leg_length=0.7, stiffness=6000.0, friction=0.9), "big")


@pytest.mark.parametrize("family, seed", [("ditch", 1000), ("step", 2000), ("mixed", 3000)])
def test_the_paper_hoppers_suite_is_make_suites(family, seed):
    assert draw_suite(family, seed).to_dict() == make_suite(family, seed).to_dict()
    assert draw_suite(family, seed, paper_hopper()).hopper is None


@pytest.mark.parametrize("family, seed", [("ditch", 1000), ("step", 2000)])
def test_the_committed_suites_are_drawn_byte_for_byte(tmp_path, family, seed):
    save_suite(draw_suite(family, seed, name=family), tmp_path / "s.json")
    assert (tmp_path / "s.json").read_bytes() == (ROOT / "suites" / f"{family}.json").read_bytes()
    assert load_suite(ROOT / "suites" / f"{family}.json").hopper is None


@pytest.mark.parametrize("family, seed", [("step", 2000), ("mixed", 3000)])
def test_a_stiffer_hoppers_suite_is_the_same_problems_in_its_units(family, seed):
    """A hopper stiffer than the paper's (k L0 / (m g) = 35.7) and grippier starts as high and as fast in its units
    and meets the same steps; its stride in leg lengths is 0.97 the paper's, so its ditches and its course are."""
    paper, big = make_suite(family, seed), draw_suite(family, seed, BIG)
    scales = suite_scales(BIG.params)
    length, speed = 1.4, math.sqrt(1.4)
    assert (scales.length, scales.speed, scales.terrain_height, *scales.start_heights) == pytest.approx(
        (length, speed, length, 1.0, 1.0))
    assert 0.9 * length < scales.stride < length
    assert big.goal_x == pytest.approx(-1.4 + 11.0 * scales.stride) and big.friction == 0.9
    assert big.hopper == BIG and suite_hopper(big) == BIG and suite_hopper(paper) == paper_hopper()
    assert len(big.cases) == len(paper.cases)
    for p, b in zip(paper.cases, big.cases):
        assert b.terrain.cell == pytest.approx(p.terrain.cell * length)
        assert b.terrain.x0 == pytest.approx(p.terrain.x0 * length)
        if family == "step":
            np.testing.assert_allclose(b.terrain.heights, p.terrain.heights * length)
        assert b.apex.x == pytest.approx(p.apex.x * length) and b.apex.xdot == pytest.approx(p.apex.xdot * speed)
        above = (b.apex.z - b.terrain.height_at(b.apex.x), p.apex.z - p.terrain.height_at(p.apex.x))
        assert above[0] == pytest.approx(above[1] * length)
    assert big.cases[0].id == f"{family}-{seed}-v{speed:g}-z{0.8 * length:g}"


def test_a_softer_hoppers_suite_follows_its_physics():
    """k L0 / (m g) = 10 and friction 0.6: starts whose vertical drop compresses the spring by the fraction of the
    stroke the paper's do, slower starts, lower steps and narrower ditches and a shorter course, by its stride; its
    steps' segments and its islands stay where the paper's are in its lengths."""
    soft = NamedHopper(SlipParams(mass=5.0, leg_length=0.4, stiffness=10 * 5.0 * 9.81 / 0.4, friction=0.6), "soft")
    scales = suite_scales(soft.params)
    kd, stroke, paper_kd = 10.0, 0.4, 3200 * 0.5 / (7 * 9.81)
    for z, factor in zip((0.8, 1.0), scales.start_heights):
        h = z / 0.5 * factor   # the start in leg lengths above the ground
        drop = (1 + math.sqrt(1 + 2 * kd * (h - 1))) / kd / stroke   # the compression of a vertical drop from h
        paper_drop = (1 + math.sqrt(1 + 2 * paper_kd * (z / 0.5 - 1))) / paper_kd / stroke
        assert drop == pytest.approx(paper_drop)   # as a fraction of the stroke
    assert 1.05 < 0.8 / 0.5 * scales.start_heights[0] < 1.2 < 1.0 / 0.5 * scales.start_heights[1] < 1.3
    assert scales.speed == pytest.approx(math.sqrt(0.8) * math.sqrt(kd / paper_kd) * math.atan(0.6) / math.atan(0.8))
    assert 0.1 * 0.8 < scales.terrain_height < 0.3 * 0.8 and 0.3 * 0.8 < scales.stride < 0.6 * 0.8
    steps, paper = draw_suite("step", 2000, soft), make_suite("step", 2000)
    np.testing.assert_allclose(steps.cases[0].terrain.heights, paper.cases[0].terrain.heights * scales.terrain_height)
    ditches, paper = draw_suite("ditch", 1000, soft), make_suite("ditch", 1000)
    assert ditches.goal_x == pytest.approx(-0.8 + 11.0 * scales.stride)
    mine, theirs = (np.diff(np.r_[0, (t.heights <= t.ditch_height).astype(int), 0]) for t in
                    (ditches.cases[0].terrain, paper.cases[0].terrain))
    widths = [np.flatnonzero(d == -1) - np.flatnonzero(d == 1) for d in (mine, theirs)]
    assert widths[0].sum() < 0.7 * widths[1].sum() and widths[0].min() >= 1
    starts = sorted({(round(c.apex.xdot, 9), round(c.apex.z, 9)) for c in ditches.cases})
    assert [v for v, _ in starts[::2]] == pytest.approx([v * scales.speed for v in (1.0, 1.5, 2.0, 2.5, 3.0)])
    assert all(c.apex.x == pytest.approx(-0.8) for c in ditches.cases)


def test_a_suite_keeps_its_hopper_and_ditch_heights_through_a_file(tmp_path):
    tall = NamedHopper(SlipParams(mass=30.0, leg_length=2.0, stiffness=20000.0), "tall")   # levels down to -1.2 m
    suite = draw_suite("mixed", 3000, tall, n_terrains=2, speeds=(2.0,), heights=(1.0,))
    assert any(c.terrain.ditch_height < -1.0 for c in suite.cases)
    save_suite(suite, tmp_path / "s.json")
    again = load_suite(tmp_path / "s.json")
    assert again.to_dict() == suite.to_dict() and again.hopper.params == tall.params
    for a, b in zip(again.cases, suite.cases):
        assert a.terrain.ditch_height == b.terrain.ditch_height
        np.testing.assert_array_equal(a.terrain.heights, b.terrain.heights)


def profiles(folder: Path) -> Path:
    folder.mkdir()
    (folder / "ridge.csv").write_text("x,height\n-3,0\n0.5,\n0.9,0.2\n2,0\n")
    (folder / "ledge.txt").write_text("# cell: 0.1, x0: -2\n" + "0\n" * 25 + "-inf\n" * 4 + "-0.15\n" * 30)
    (folder / "notes.md").write_text("not a profile")
    return folder


def test_a_folder_of_profiles_makes_a_suite(tmp_path):
    suite = suite_from_terrains(profiles(tmp_path / "mine"), speeds=(1.0, 2.0), heights=(0.8,))
    assert suite.name == "mine" and suite.hopper is None and suite.friction == 0.8 and suite.goal_x == 10.0
    assert [c.id for c in suite.cases] == ["ledge-v1-z0.8", "ledge-v2-z0.8", "ridge-v1-z0.8", "ridge-v2-z0.8"]
    for case in suite.cases:
        assert case.apex.x == -1.0 and case.apex.z == pytest.approx(0.8 + case.terrain.height_at(-1.0))
    ledge, ridge = suite.cases[0].terrain, suite.cases[2].terrain
    assert ledge.is_ditch_at(0.65) and not ledge.is_ditch_at(0.95) and ledge.height_at(0.95) == -0.15
    assert ridge.is_ditch_at(0.7) and ridge.height_at(1.0) == 0.2
    save_suite(suite, tmp_path / "s.json")
    assert load_suite(tmp_path / "s.json").to_dict() == suite.to_dict()


def test_profiles_for_another_hopper_start_in_its_units(tmp_path):
    suite = suite_from_terrains(profiles(tmp_path / "mine"), BIG)
    assert len(suite.cases) == 2 * 10 and suite.hopper == BIG and suite.friction == 0.9
    assert suite.goal_x == pytest.approx(-1.4 + 11.0 * suite_scales(BIG.params).stride)   # 11 m in its strides
    assert suite.cases[0].apex.x == pytest.approx(-1.4)
    assert suite.cases[0].apex.xdot == pytest.approx(math.sqrt(1.4))
    assert json.loads(json.dumps(suite.to_dict()))["hopper"]["params"]["mass"] == 12.0


def test_bad_profile_suites_are_refused(tmp_path):
    folder = profiles(tmp_path / "mine")
    with pytest.raises(ValueError, match=r"ledge.txt: the start x=0.6 is over a ditch"):
        suite_from_terrains(folder, start_x=0.6)
    with pytest.raises(ValueError, match="goal_x=-2 must lie ahead of start_x=-1"):
        suite_from_terrains(folder, goal_x=-2.0)
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "ridge.txt").write_text("# cell: 0.1, x0: -2\n0\n")
    with pytest.raises(ValueError, match="share the name 'ridge'"):
        suite_from_terrains([folder / "ridge.csv", tmp_path / "other" / "ridge.txt"])
    with pytest.raises(ValueError, match="has no .csv or .txt files"):
        suite_from_terrains(tmp_path / "other" / "..")
    with pytest.raises(ValueError, match="start speed must be a positive"):
        suite_from_terrains(folder, speeds=(0.0,))
