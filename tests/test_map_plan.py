"""Map plans (planners/formats/map_plan.py) and their checks (verification/map_plan_check.py,
verification/map_robustness.py): make_plan.py on a height-map suite writes a file that reads back as written; a
malformed file is refused naming the field; verify_plan.py certifies a plan the spatial SLIP flies as written, gives
the first place a run leaves a plan that it does not, runs it on the spatial robot, and refuses what does not go with
a map plan in one line; robustness.py draws noisy hoppers for it, repeatably, on the SLIP and on the robot."""
import json
from types import SimpleNamespace

import numpy as np
import pytest

from drakeslip.hopper_file import paper_hopper
from drakeslip.noise import PROFILES
from drakeslip.params import SlipParams
from drakeslip.spatial.heightmap import HeightMap
from drakeslip.spatial.noise import apex_errors3d
from planners.formats.map_plan import MAP_PLAN_FORMAT, MapPlanRecord, is_map_plan, load_map_plan, save_map_plan
from planners.formats.map_suite import MAP_SUITE_FORMAT, map_digest, map_suite_from_dict
from planners.registry import make
from planners.spatial_loop import perception_window
from planners.search.spatial_problem import goal_reach
from verification.map_plan_check import check_map_plan, compare, edge_distance
from verification.map_robustness import map_success_probability

GAP = (2.0, 2.3)   # [m] along x: the hole band across the map


def flat_with_a_gap() -> HeightMap:
    """Flat ground from x = -3 to 9 m, 2 m wide, a 0.3 m gap across it at x = 2 m."""
    heights = np.zeros((40, 240))
    heights[:, 100:106] = np.nan
    return HeightMap(heights, 0.05, (-3.0, -1.0))


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """A map suite of one case on the user's map maps/m.npz, in a folder of its own."""
    folder = tmp_path_factory.mktemp("map_plan")
    (folder / "maps").mkdir()
    height_map = flat_with_a_gap()
    height_map.save(folder / "maps" / "m.npz")
    suite = {"format": MAP_SUITE_FORMAT, "name": "mine", "goal": {"x": 5.0, "y": 0.0}, "friction": 0.8,
             "cases": [{"id": "one", "map": {"file": "maps/m.npz", "sha256": map_digest(height_map)},
                        "apex": {"x": 0.0, "y": 0.0, "z": 0.8, "xdot": 1.5, "ydot": 0.0}}]}
    (folder / "suite.json").write_text(json.dumps(suite))
    return folder


@pytest.fixture(scope="module")
def saved(folder):
    """A step plan of the suite's case, saved as make_plan.py saves one: (its path, the record)."""
    suite = map_suite_from_dict(json.loads((folder / "suite.json").read_text()), "suite", folder)
    case, params = suite.cases[0], SlipParams().with_friction(suite.friction)
    plan = make("step").plan(case.apex, perception_window(case.terrain, case.apex, case.goal, params), case.goal,
                             params)
    assert plan.success, plan.message
    (folder / "plans").mkdir()
    path = folder / "plans" / "plan.json"
    return path, save_map_plan(path, plan, case, suite.sources[0], params, paper_hopper())


def test_a_map_plan_reads_back_as_written(saved):
    path, record = saved
    document = json.loads(path.read_text())
    assert document["format"] == MAP_PLAN_FORMAT and document["map"]["file"] == "../maps/m.npz"
    loaded = load_map_plan(path)
    for name in ("footholds", "leg_angles", "apexes"):
        assert np.array_equal(getattr(loaded, name), getattr(record, name), equal_nan=True)
    assert (loaded.apex, loaded.goal, loaded.target, loaded.params) == (record.apex, record.goal, record.target,
                                                                       record.params)
    assert np.array_equal(loaded.height_map.heights, record.height_map.heights, equal_nan=True)
    assert loaded.footholds[-1][0] > GAP[1] and loaded.target == (5.0, 0.0)


def edited(path, change, tmp_path):
    """A copy of the plan file at ``path`` in ``path``'s folder, changed by ``change(document)``."""
    document = json.loads(path.read_text())
    change(document)
    out = path.parent / f"edited-{tmp_path.name}.json"
    out.write_text(json.dumps(document))
    return out


def into_the_gap(d):
    d["footholds"][0][0] = 2.1


@pytest.mark.parametrize("change, message", [
    (lambda d: d.update(format="drakeslip-plan/2"), r"format must be 'drakeslip-map-plan/1'"),
    (into_the_gap, r"footholds\[0\] \(2\.1, .*\) is over a hole of the map"),
    (lambda d: d["footholds"][1].__setitem__(2, 0.2), r"footholds\[1\]\.z = 0\.2 m is not the map's height"),
    (lambda d: d["footholds"][0].pop(), r"footholds\[0\] must be a list of 3 numbers"),
    (lambda d: d["leg_angles"][0].__setitem__(1, 2.0), r"leg_angles\[0\]\[1\] = 2 is outside \(-pi/2, pi/2\)"),
    (lambda d: d["apexes"][0].__setitem__(3, None), r"apexes\[0\] is given in part"),
    (lambda d: d["apexes"].pop(), r"footholds need .* leg angles \[pitch, roll\] and .* apexes"),
    (lambda d: d["apex"].update(z=-1.0), r"the start apex"),
    (lambda d: d["map"].update(sha256="a" * 64), r"map\.sha256: the height map file .*m\.npz has digest"),
    (lambda d: d["hopper"]["params"].update(mass=9.0), r"hopper"),
    (lambda d: d.update(format="drakeslip-map-plan/9"), r"format must be 'drakeslip-map-plan/1', got '.*/9'"),
    (lambda d: d["apex"].update(x="a"), r"^plan file \S+: apex\.x must be a finite number"),   # the file named once
    (lambda d: d["target"].update(y="a"), r"^plan file \S+: target\.y must be a finite number"),
])
def test_a_malformed_map_plan_is_refused_naming_the_field(saved, tmp_path, change, message):
    with pytest.raises(ValueError, match=message):
        load_map_plan(edited(saved[0], change, tmp_path))


def test_another_version_of_the_map_plan_format_is_refused_as_a_map_plan():
    """A map plan of a version this code does not read goes to the map plan's reader, which names the version it
    reads, not to the profile plan's."""
    assert is_map_plan({"format": "drakeslip-map-plan/9"}) and is_map_plan({"format": MAP_PLAN_FORMAT})
    assert not is_map_plan({"format": "drakeslip-plan/2"}) and not is_map_plan({"format": None})


def test_the_slip_flies_the_plan_as_written_with_its_margins(saved):
    _, record = saved
    verdict = check_map_plan(record, "angles", 0.01)
    assert verdict.ok, verdict.format()
    assert len(verdict.footholds) == len(record.footholds) and verdict.deviation[0] < 1e-4
    margins = verdict.margins
    assert 0 < margins["friction"][0] < record.params.friction and 0 < margins["stroke"][0] < 0.2
    assert 0 < margins["body_clearance"][0] < 1.0
    # the nearest edge of a foothold is the gap's: the footholds around it say how far they landed from it
    nearest = min(min(abs(f[0] - GAP[0]), abs(f[0] - GAP[1])) for f in record.footholds)
    assert margins["edge_distance"][0] == pytest.approx(nearest, abs=1e-5)   # the run lands within 1e-5 m


def test_a_run_that_leaves_the_plan_is_the_counterexample(saved):
    _, record = saved
    offset = np.zeros_like(record.footholds)
    offset[0, 1] = 0.05   # the first foothold 5 cm aside: the plan's angles do not land there
    moved = MapPlanRecord(**{**record.__dict__, "footholds": record.footholds + offset})
    verdict = check_map_plan(moved, "angles", 0.01)
    assert not verdict.ok and (verdict.kind, verdict.hop) == ("foothold", 0)
    assert verdict.actual[1] == pytest.approx(record.footholds[0][1], abs=1e-6)
    short = MapPlanRecord(**{**record.__dict__, "footholds": record.footholds[:1], "leg_angles": record.leg_angles[:1],
                             "apexes": record.apexes[:1]})
    verdict = check_map_plan(short, "footholds", 0.01)
    assert not verdict.ok and (verdict.kind, verdict.hop) == ("target", 0)


def test_the_target_is_reached_as_the_planners_goal_test_asks():
    """The last hop's way runs from the foothold before it (the body's apex only for a first hop), as the search's
    goal test has it: here it passes the goal, while the way from the apex before would pass 0.8 m from it."""
    record = SimpleNamespace(footholds=np.array([[4.0, 0.0, 0.0], [6.0, 0.0, 0.0]]), apexes=np.full((2, 5), np.nan),
                             apex=(0.0, 0.0, 0.8, 1.5, 0.0), target=(5.0, 0.0), reach=goal_reach((5.0, 0.0), 0.5))
    touchdowns, apexes = [(4.0, 0.0, 0.0), (6.0, 0.0, 0.0)], [(4.5, 2.0, 0.8, 1.0, -1.0), (6.5, 0.0, 0.8, 1.0, 0.0)]
    assert compare(record, "footholds", 0.01, "drake", touchdowns, apexes, None).ok
    short = SimpleNamespace(**{**record.__dict__, "target": (7.0, 0.0), "reach": goal_reach((7.0, 0.0), 0.5)})
    verdict = compare(short, "footholds", 0.01, "drake", touchdowns, apexes, None)
    assert not verdict.ok and (verdict.kind, verdict.hop) == ("target", 1)


def test_edge_distance_is_to_the_nearest_cell_of_another_height():
    heights = np.zeros((20, 20))
    heights[:, 12:] = 0.1
    heights[3, 2] = np.nan
    m = HeightMap(heights, 0.1, (0.0, 0.0))
    assert edge_distance(m, 0.95, 1.0, 1.0) == pytest.approx(0.25)
    assert edge_distance(m, 0.25, 0.45, 1.0) == pytest.approx(0.05)   # the hole's cell, 5 cm above it
    assert edge_distance(m, 0.05, 1.5, 0.3) == float("inf")


def test_verify_plan_certifies_on_drake_and_runs_the_robot(run_script, saved, tmp_path):
    path, _ = saved
    out_json, png, html = tmp_path / "check.json", tmp_path / "check.png", tmp_path / "check.html"
    code, out, err = run_script("verify_plan", "--plan", path, "--out", out_json, "--plot", png, "--html", html)
    assert code == 0, err
    assert "CERTIFIED on the spatial SLIP on Drake (leg angles open loop)" in out and "edge_distance" in out
    document = json.loads(out_json.read_text())
    assert document["verdict"] == "certified" and document["hopper"]["name"] == "paper"
    assert png.stat().st_size > 10_000 and "planned footholds" in html.read_text()
    code, out, err = run_script("verify_plan", "--plan", path, "--backend", "multibody", "--tolerance", "0.5",
                                "--plot", png)
    assert code in (0, 1), err
    assert "on the spatial robot (footholds through the controller)" in out and "largest body roll" in out


@pytest.mark.parametrize("args, message", [
    (("--terrain", "PROFILE"), "--terrain takes a height profile: a map plan is checked on its own map"),
    (("--backend", "multibody", "--mode", "angles"), "--backend multibody flies the plan's footholds"),
    (("--hopper", "paper", "--tolerance", "0"), "--tolerance"),
])
def test_what_does_not_go_with_a_map_plan_is_refused_in_one_line(run_script, saved, tmp_path, args, message):
    profile = tmp_path / "ground.csv"
    profile.write_text("x,height\n0,0\n10,0\n")
    args = [profile if a == "PROFILE" else a for a in args]
    code, out, err = run_script("verify_plan", "--plan", saved[0], *args)
    assert code == 2 and message in err and len(err.strip().splitlines()) <= 2, err


def test_make_plan_writes_a_map_plan_from_a_map_suite(run_script, folder, tmp_path):
    out, png = tmp_path / "p.json", tmp_path / "p.png"
    code, text, err = run_script("make_plan", "--suite", folder / "suite.json", "--case", "one", "--planner", "step",
                                 "--out", out, "--plot", png)
    assert code == 0, err
    assert "step on one: " in text and f"wrote {out}" in text and png.stat().st_size > 10_000
    record = load_map_plan(out)
    assert record.footholds[-1][0] > GAP[1] and record.hopper.name == "paper"


@pytest.mark.parametrize("args, message", [
    (["--suite", "{folder}/suite.json", "--case", "one", "--planner", "angle"],
     "--planner angle plans on profiles only, not on the height maps of"),
    (["--terrain", "{folder}/maps/m.npz", "--planner", "step"], "is a height map file; this --terrain takes a terrain "
                                                                  "profile"),
])
def test_make_plan_refuses_what_does_not_plan_a_map_in_one_line(run_script, folder, tmp_path, args, message):
    code, text, err = run_script("make_plan", *[a.format(folder=folder) for a in args], "--out", tmp_path / "p.json")
    assert code == 2 and message in err and len(err.splitlines()) == 1 and not text, err
    assert not (tmp_path / "p.json").exists()


def test_noiseless_draws_fly_a_certified_plan_and_a_seed_repeats_its_draws(saved):
    _, record = saved
    # the fast step map is the planner's: without noise every draw flies the plan; Drake aims through the controller,
    # which lands each foothold from the apex Drake reached, a hair off the planner's, so it is checked over the hops
    # that stay within the tolerance of the plan's apexes (verify_plan.py --mode footholds says how many)
    assert map_success_probability(record, 3, PROFILES["none"]).successes == 3
    kept = check_map_plan(record, "footholds", 0.01)
    hops = len(record.footholds) if kept.ok else kept.hop
    assert hops >= 3 and map_success_probability(record, 2, PROFILES["none"], backend="drake", hops=hops).successes == 2
    noisy = [map_success_probability(record, 40, PROFILES["realistic"], seed=5, hops=2) for _ in range(2)]
    assert np.array_equal(noisy[0].failures, noisy[1].failures)
    assert all(np.array_equal(a.apex_errors, b.apex_errors) for a, b in zip(noisy[0].draws, noisy[1].draws))
    # the draws come in the planar order: the apex errors first, from the seed's generator
    rng = np.random.default_rng(5)
    assert np.array_equal(noisy[0].draws[0].apex_errors,
                          apex_errors3d(PROFILES["realistic"].for_hopper(record.params), rng, 2))
    assert noisy[0].draws[0].apex_errors.shape == (2, 5) and noisy[0].draws[0].angle_errors.shape == (2, 2)
    # a draw keeps the heights its sensed map has at the footholds it aims at, not the map (a thousand maps: a GB)
    heights = noisy[0].draws[0].sensed
    assert heights.shape == (2,) and np.all(np.abs(heights - record.footholds[:2, 2]) < 0.1)
    assert any(not np.array_equal(a.sensed, b.sensed) for a, b in zip(noisy[0].draws, noisy[0].draws[1:]))
    # ten times the noise fails more often than the profile itself
    wild = map_success_probability(record, 40, PROFILES["realistic"].scaled(10.0), seed=5, hops=2)
    assert wild.successes < noisy[0].successes


def test_robustness_runs_a_map_plan_with_its_figure_and_on_the_robot(run_script, saved, tmp_path):
    path, _ = saved
    out_json, png = tmp_path / "r.json", tmp_path / "r.png"
    code, out, err = run_script("robustness", "--plan", path, "--samples", "30", "--hops", "2", "--drake", "3",
                                "--out", out_json, "--plot", png)
    assert code == 0, err
    assert "plan on a height map" in out and "footholds; on Drake without noise: " in out
    assert "30 draws on the fast backend" in out and "Drake rerun of the first 3 draws" in out
    document = json.loads(out_json.read_text())
    assert document["n"] == 30 and len(document["draws"]["apex_errors"][0][0]) == 5
    assert png.stat().st_size > 10_000
    code, out, err = run_script("robustness", "--plan", path, "--samples", "2", "--hops", "1", "--backend",
                                "multibody", "--out", out_json)
    assert code == 0, err
    assert "2 draws on the multibody backend" in out
    assert json.loads(out_json.read_text())["robot"]["model"] == "drakeslip/spatial/multibody/robot.sdf"
