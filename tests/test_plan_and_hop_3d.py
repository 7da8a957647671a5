"""examples/plan_and_hop.py on height maps (verification/map_run.py): a map family's draw and a user's .npz map
planned for and hopped over end to end, with the figure and the replay, by the spatial SLIP and by the spatial robot;
every input the map loop cannot run
refused in one line, exit status 2, before any work; --help names the height-map families."""
import base64
import re

import numpy as np
import pytest

from drakeslip.spatial.families import HEIGHT_MAP_FAMILIES

HOLE = (1.5, 1.8)   # [m] along x: the hole band across the user's map


@pytest.fixture
def user_map(tmp_path):
    """A user's .npz map: flat ground at 0 over x in [-3, 12), y in [-3, 3) in 10 cm cells, a hole band across it."""
    x = -3.0 + (np.arange(150) + 0.5) * 0.1
    heights = np.zeros((60, 150))
    heights[:, (x >= HOLE[0]) & (x < HOLE[1])] = np.nan
    path = tmp_path / "ground.npz"
    np.savez(path, heights=heights, cell=0.1, origin=np.array([-3.0, -3.0]))
    return path


def embedded_commands(page_text: str) -> list:
    """The Meshcat commands a self-contained replay page carries (base64 blobs)."""
    return [base64.b64decode(b) for b in re.findall(r"data:application/octet-binary;base64,([A-Za-z0-9+/=]+)",
                                                    page_text)]


def test_a_map_family_is_planned_and_hopped_with_its_figure_and_replay(run_script, tmp_path):
    png, html = tmp_path / "blocks.png", tmp_path / "blocks.html"
    code, out, err = run_script("plan_and_hop", "--terrain", "blocks", "--difficulty", "0.2", "--goal", "4,0",
                                "--out", png, "--html", html)
    assert code == 0, err
    summary = next(line for line in out.splitlines() if "reached the goal" in line)
    assert "blocks height map seed 3, difficulty 0.2" in summary and "hops" in summary
    assert "planning calls" in summary and "mean plan time" in summary
    assert out.count("\nplan ") >= 1 and f"wrote {png}" in out and f"replay: {html}" in out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    text = html.read_text()
    assert "plan_and_hop.py: step on blocks height map" in text and "planned footholds" in text
    animation = [c for c in embedded_commands(text) if b"set_animation" in c]
    assert len(animation) == 1 and b"/drakeslip/world/hopper/body" in animation[0]


def test_a_users_npz_map_is_hopped_over_its_hole(run_script, tmp_path, user_map):
    png = tmp_path / "user.png"
    code, out, err = run_script("plan_and_hop", "--terrain", user_map, "--goal", "4", "--out", png)
    assert code == 0, err
    assert f"height map file {user_map}: reached the goal" in out and png.stat().st_size > 10_000
    # the fast step map draws the path through the plans' apexes instead of a Drake trajectory
    code, out, err = run_script("plan_and_hop", "--terrain", user_map, "--goal", "4,0", "--backend", "fast",
                                "--out", png)
    assert code == 0 and "(fast, replanning every 3 hops)" in out, err


def test_the_spatial_robot_hops_a_users_map_with_its_figure_and_replay(run_script, tmp_path, user_map):
    png, html = tmp_path / "robot.png", tmp_path / "robot.html"
    code, out, err = run_script("plan_and_hop", "--terrain", user_map, "--goal", "4,0", "--backend", "multibody",
                                "--out", png, "--html", html)
    assert code == 0, err
    assert "(multibody, replanning every 1 hops)" in out and "reached the goal" in out
    robot = next(line for line in out.splitlines() if line.startswith("the spatial robot:"))
    assert "touchdowns" in robot and "largest roll" in robot and "s simulated in" in robot
    assert png.stat().st_size > 10_000 and f"replay: {html}" in out
    text = html.read_text()
    assert "on the spatial robot" in text and "hip gimbal" in text and "no failure" in text
    animation = [c for c in embedded_commands(text) if b"set_animation" in c]
    assert len(animation) == 1 and b"/drakeslip/world/robot/body" in animation[0]


@pytest.mark.parametrize("args, named", [
    (["--terrain", "warp"], "'warp' is neither a terrain family"),
    (["--terrain", "gaps", "--difficulty", "2"], "--difficulty: must be a finite number >= 0.0 and <= 1.0, got '2'"),
    (["--terrain", "gaps", "--goal", "1,nan"], "--goal: must be a finite number"),
    (["--terrain", "gaps", "--goal", "a,b"], "--goal: must be a number, got 'a'"),
    (["--terrain", "gaps", "--goal=-2,0"], "the goal (-2, 0) must lie ahead of the start x=-1"),
    (["--terrain", "{tmp}/missing.npz"], "height map file {tmp}/missing.npz: cannot be read"),
    (["--terrain", "{tmp}/bad.npz"], "height map file {tmp}/bad.npz lacks cell, origin"),
    (["--terrain", "gaps", "--planner", "angle"], "--planner angle: the 'angle' planner plans on profiles"),
    (["--terrain", "gaps", "--planner", "trajopt"], "--planner trajopt:"),
    (["--terrain", "{map}", "--start-x", "1.6"], "the start (x, y) = (1.6, 0) is over a hole of the map"),
    (["--terrain", "{map}", "--start-x", "20"], "the start (x, y) = (20, 0) is not over the map"),
    (["--terrain", "gaps", "--backend", "fast", "--html", "{tmp}/r.html"], "--html: the fast backend"),
    (["--terrain", "{map}", "--difficulty", "0.5"], "--difficulty draws a height-map family"),
    (["--terrain", "step", "--goal", "3,1"], "--goal: a point X,Y is a height map's goal; on a terrain profile the "
                                             "goal is an x, got 3,1"),
    (["--terrain", "step", "--difficulty", "0.5"], "--difficulty draws a height-map family"),
])
def test_what_the_map_loop_cannot_run_is_refused_in_one_line_before_any_work(run_script, tmp_path, user_map, args,
                                                                              named):
    np.savez(tmp_path / "bad.npz", heights=np.zeros((3, 3)))
    fill = lambda s: s.replace("{tmp}", str(tmp_path)).replace("{map}", str(user_map))   # noqa: E731
    code, out, err = run_script("plan_and_hop", *map(fill, args), "--out", tmp_path / "x.png")
    assert code == 2 and not out, err
    assert len(err.splitlines()) == 1 and fill(named) in err, err
    assert not (tmp_path / "x.png").exists()


def test_help_names_the_height_map_families_and_the_point_goal(run_script):
    code, out, _ = run_script("plan_and_hop", "--help")
    assert code == 0 and "--difficulty" in out and "X,Y" in out
    assert all(name in out for name in HEIGHT_MAP_FAMILIES)
