"""Height-map suites (planners/formats/map_suite.py): a file round trip, every field checked on load (a tampered map
digest, a bad apex, an unknown family refused naming the field), examples/make_suites.py writing one per map family
(beside the planar ones, for another hopper in its units), and examples/evaluate.py taking one as it takes a planar
suite: end to end on drawn maps and on a user's .npz map, its cache reused, its unsupported options refused."""
import copy
import json
import math

import numpy as np
import pytest

from drakeslip import SlipParams
from drakeslip.hopper_file import NamedHopper, save_hopper
from drakeslip.spatial.families import HEIGHT_MAP_FAMILIES
from drakeslip.spatial.heightmap import HeightMap
from planners.formats.map_suite import (MAP_SUITE_FORMAT, is_map_suite, load_map_suite, make_map_suite,
                                        map_digest, map_suite_from_dict, save_map_suite)

FAMILIES = "gaps,stones,stairs,blocks,course"


@pytest.fixture(scope="module")
def small():
    """Two gaps maps (difficulty 0 and 1) x two starts."""
    return make_map_suite("gaps", 40, n_maps=2, speeds=(1.5,), heights=(0.8, 1.0))


def test_a_map_suite_round_trips_through_its_file(tmp_path, small):
    save_map_suite(small, tmp_path / "s.json")
    document = json.loads((tmp_path / "s.json").read_text())
    assert is_map_suite(document) and document["format"] == MAP_SUITE_FORMAT and not is_map_suite({"format": "x"})
    assert document["goal"] == {"x": 10.0, "y": 0.0} and "hopper" not in document
    assert [c["map"]["difficulty"] for c in document["cases"]] == [0.0, 0.0, 1.0, 1.0]
    assert document["cases"][0]["apex"] == {"x": -1.0, "y": 0.0, "z": 0.8, "xdot": 1.5, "ydot": 0.0}
    back = load_map_suite(tmp_path / "s.json")
    assert back.to_dict() == small.to_dict() and back.friction == 0.8 and back.goal == (10.0, 0.0)
    for a, b in zip(small.cases, back.cases):
        assert (a.id, a.apex, a.goal) == (b.id, b.apex, b.goal)
        np.testing.assert_array_equal(a.terrain.heights, b.terrain.heights)   # NaN holes included


def refused(document, message, tmp_path=None):
    with pytest.raises(ValueError, match=message) as error:
        map_suite_from_dict(document, "s", tmp_path)
    assert "\n" not in str(error.value)


def edited(document, edit):
    document = copy.deepcopy(document)
    edit(document)
    return document


@pytest.mark.parametrize("edit, message", [
    (lambda d: d["cases"][1]["map"].update(sha256="0" * 64), r"s: cases\[1\]\.map\.sha256: the 'gaps' map of seed 40"),
    (lambda d: d["cases"][2]["map"].update(seed=42), r"cases\[2\]\.map\.sha256: .* not the suite's"),
    (lambda d: d["cases"][3]["apex"].update(ydot="fast"), r"cases\[3\]\.apex\.ydot must be a finite number"),
    (lambda d: d["cases"][3]["apex"].update(ydot=1e9), r"cases\[3\]\.apex\.ydot must be a finite number in"),
    (lambda d: d["cases"][0]["apex"].update(z=-0.1), r"cases\[0\]\.apex: apex z=-0.1 is not above the map"),
    (lambda d: d["cases"][0]["apex"].update(xdot=0.0), r"cases\[0\]\.apex: horizontal speed 0 m/s must be above 0"),
    (lambda d: d["cases"][0]["map"].update(family="hills"), r"cases\[0\]\.map\.family must be one of \['blocks'"),
    (lambda d: d["cases"][0]["map"].update(difficulty=2), r"cases\[0\]\.map\.difficulty must be .* in \[0, 1\]"),
    (lambda d: d["cases"][0]["map"].pop("seed"), r"cases\[0\]\.map is missing the field 'seed'"),
    (lambda d: d["cases"][0]["map"].update(file="m.npz"), r"cases\[0\]\.map must name either a drawn map"),
    (lambda d: d["cases"][1].update(id=d["cases"][0]["id"]), r"cases\[1\]\.id must be unique"),
    (lambda d: d["cases"][1].update(goal={"x": 3.0}), r"cases\[1\]\.goal is missing the field 'y'"),
    (lambda d: d["goal"].update(y=math.inf), r"s: goal\.y must be a finite number"),
    (lambda d: d.update(format="drakeslip-suite/1"), r"format must be 'drakeslip-map-suite/1'"),
])
def test_every_field_is_checked_and_a_bad_one_named(small, edit, message):
    refused(edited(small.to_dict(), edit), message)


def flat_with_a_gap() -> HeightMap:
    """Flat ground from x = -3 to 9 m, 2 m wide, a 0.3 m gap across it at x = 2 m."""
    heights = np.zeros((40, 240))
    heights[:, 100:106] = np.nan
    return HeightMap(heights, 0.05, (-3.0, -1.0))


def file_suite(tmp_path, digest=None) -> dict:
    """A suite of two starts on the user's map maps/m.npz, the second with a goal of its own."""
    (tmp_path / "maps").mkdir(exist_ok=True)
    height_map = flat_with_a_gap()
    height_map.save(tmp_path / "maps" / "m.npz")
    record = {"file": "maps/m.npz", "sha256": digest or map_digest(height_map)}
    return {"format": MAP_SUITE_FORMAT, "name": "mine", "goal": {"x": 6.0, "y": 0.0}, "friction": 0.8,
            "cases": [{"id": "slow", "map": record, "apex": {"x": 0.0, "y": 0.0, "z": 0.8, "xdot": 1.5, "ydot": 0.0}},
                      {"id": "fast", "map": record, "apex": {"x": 0.0, "y": 0.2, "z": 0.9, "xdot": 2.5, "ydot": 0.1},
                       "goal": {"x": 5.0, "y": 0.5}}]}


def test_a_users_map_file_is_read_relative_to_the_suite_and_checked(tmp_path):
    document = file_suite(tmp_path)
    suite = map_suite_from_dict(document, "s", tmp_path)
    assert [c.goal for c in suite.cases] == [(6.0, 0.0), (5.0, 0.5)]
    assert suite.cases[0].terrain is suite.cases[1].terrain   # read once
    (tmp_path / "out").mkdir()
    save_map_suite(suite, tmp_path / "out" / "s.json")   # its path is kept relative to where the suite is written
    assert json.loads((tmp_path / "out" / "s.json").read_text())["cases"][0]["map"]["file"] == "../maps/m.npz"
    assert load_map_suite(tmp_path / "out" / "s.json").to_dict() == suite.to_dict()
    refused(file_suite(tmp_path, "a" * 64), r"cases\[0\]\.map\.sha256: the height map file .*m\.npz has digest",
            tmp_path)
    refused(edited(document, lambda d: d["cases"][0]["map"].update(file="none.npz")),
            r"cases\[0\]\.map: height map file .*none\.npz: cannot be read", tmp_path)
    refused(edited(document, lambda d: d["cases"][0]["apex"].update(x=2.1)), r"cases\[0\]\.apex .* is over a hole",
            tmp_path)


def test_make_suites_writes_one_map_suite_per_family(run_script, tmp_path):
    code, out, err = run_script("make_suites", "--families", FAMILIES, "--seed", 58000, "--out", tmp_path)
    assert code == 0, err
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(f"{f}-58000.json" for f in HEIGHT_MAP_FAMILIES)
    for family in HEIGHT_MAP_FAMILIES:
        suite = load_map_suite(tmp_path / f"{family}-58000.json")   # every map drawn again and its digest checked
        assert len(suite.cases) == 150 and f"wrote {tmp_path / family}-58000.json: 150 cases" in out
        maps = [json.loads((tmp_path / f"{family}-58000.json").read_text())["cases"][i]["map"] for i in (0, 149)]
        assert [(m["seed"], m["difficulty"]) for m in maps] == [(58000, 0.0), (58014, 1.0)]
        assert {c.apex[3] for c in suite.cases} == {1.0, 1.5, 2.0, 2.5, 3.0} and suite.goal == (10.0, 0.0)
    code, _, err = run_script("make_suites", "--families", "gaps", "--out", tmp_path / "x")
    assert code == 2 and "['gaps'] have no committed suite; give --seed" in err and len(err.splitlines()) == 1


def test_map_and_planar_families_mix_and_a_hopper_gets_its_units(run_script, tmp_path):
    """A planar suite drawn beside a map suite is the one drawn alone; a hopper with a 0.7 m leg gets maps, starts
    and goal 1.4 times the paper's (its stiffness and friction keep the paper's starts similar)."""
    big = save_hopper(NamedHopper(SlipParams(mass=12.0, leg_length=0.7, stiffness=6000.0, friction=0.9), "big"),
                      tmp_path / "big.json")
    code, _, err = run_script("make_suites", "--families", "ditch", "--seed", 7, "--terrains", 1,
                              "--out", tmp_path / "a")
    assert code == 0, err
    code, _, err = run_script("make_suites", "--families", "gaps,ditch", "--seed", 7, "--terrains", 1,
                              "--out", tmp_path / "b")
    assert code == 0, err
    assert (tmp_path / "a" / "ditch-7.json").read_bytes() == (tmp_path / "b" / "ditch-7.json").read_bytes()
    code, _, err = run_script("make_suites", "--families", "stairs", "--seed", 7, "--terrains", 1, "--hopper",
                              tmp_path / "big.json", "--out", tmp_path / "c")
    assert code == 0, err
    suite = load_map_suite(tmp_path / "c" / "stairs-7.json")
    assert suite.hopper.params == big.params and suite.goal == pytest.approx((14.0, 0.0)) and suite.friction == 0.9
    assert suite.sources[0]["length"] == pytest.approx(1.4) and suite.cases[0].terrain.cell == pytest.approx(0.07)
    assert suite.cases[0].apex == pytest.approx((-1.4, 0.0, 0.8 * 1.4, math.sqrt(1.4), 0.0))


def evaluated(run_script, suite_path, out, *args):
    return run_script("evaluate", "--suite", suite_path, "--planners", "step", "--backend", "fast", "--quiet",
                      "--out", out, *args)


def test_evaluate_runs_a_map_suite_through_the_cache(run_script, tmp_path, small):
    save_map_suite(small, tmp_path / "s.json")
    code, out, err = evaluated(run_script, tmp_path / "s.json", tmp_path / "r.json", "--cases", 3)
    assert code == 0, err
    assert "Success %" in out and "hops a case; failures:" in out and "reused" not in out
    results = json.loads((tmp_path / "r.json").read_text())
    cases = results["planners"]["step"]["cases"]
    assert [c["id"] for c in cases] == [c.id for c in small.cases[:3]]
    assert all(isinstance(c["success"], bool) and len(c["final"]) == 2 for c in cases)
    assert results["suite"] == "gaps-40" and results["planners"]["step"]["config"]["backend"] == "fast"
    code, again, err = evaluated(run_script, tmp_path / "s.json", tmp_path / "r.json", "--cases", 3)
    assert code == 0 and "3 of 3 results reused" in again, err
    assert json.loads((tmp_path / "r.json").read_text())["planners"]["step"]["cases"] == cases


def test_evaluate_runs_a_users_map_file(run_script, tmp_path):
    (tmp_path / "s.json").write_text(json.dumps(file_suite(tmp_path)))
    code, out, err = evaluated(run_script, tmp_path / "s.json", tmp_path / "r.json")
    assert code == 0, err
    cases = json.loads((tmp_path / "r.json").read_text())["planners"]["step"]["cases"]
    assert [c["id"] for c in cases] == ["slow", "fast"] and all(c["success"] for c in cases), cases
    assert cases[0]["final"][0] >= 6.0 - 0.5


@pytest.mark.parametrize("args, message", [
    (["--backend", "multibody", "--no-pump"], "--no-pump: not applied on height maps"),
    (["--backend", "fast", "--mlp-only"], "--mlp-only: not applied on height maps"),
    (["--backend", "fast", "--map-filter", "5"], "--map-filter 5 filters the map a noisy robot senses: give --noise"),
    (["--template", "{suite}"], "--template needs --backend multibody"),
    (["--backend", "multibody", "--template", "{suite}"], "s.json is not a spatial template fit"),
    (["--backend", "fast", "--planners", "angle"], "planners angle plan on profiles only, not on height maps"),
    (["--backend", "fast", "--planners", "step@drake", "--options", '{{"step@drake": {{"step_map": "drake"}}}}'],
     "step@drake: the 'step' planner plans on a height map without step_map='drake'"),
    (["--backend", "fast", "--planners", "lstm-guided@drake", "--options",
      '{{"lstm-guided@drake": {{"step_map": "drake"}}}}'],
     "lstm-guided@drake: the 'lstm-guided' planner plans on a height map without step_map='drake'"),
    (["--backend", "fast", "--planners", "step@robust", "--options",
      '{{"step@robust": {{"robustness": {{"depth": 4}}}}}}'],
     "step@robust: robustness depth=4 is a planar search setting"),
])
def test_evaluate_refuses_what_the_map_loop_does_not_run(run_script, tmp_path, small, args, message):
    save_map_suite(small, tmp_path / "s.json")
    args = [a.format(suite=tmp_path / "s.json") for a in args]
    code, out, err = run_script("evaluate", "--suite", tmp_path / "s.json", "--planners", "step", *args,
                                "--out", tmp_path / "r.json")
    assert code == 2 and message in err and len(err.splitlines()) == 1 and not out, err
    assert not (tmp_path / "r.json.cases.jsonl").exists()


def test_planning_speed_times_the_planners_on_a_map_suite(run_script, tmp_path, small):
    save_map_suite(small, tmp_path / "s.json")
    code, out, err = run_script("planning_speed", "--suites", tmp_path / "s.json", "--planners", "step,lstm-guided",
                                "--pairs", "step:lstm-guided", "--cases", 2, "--repeats", 1)
    assert code == 0, err
    rows = {line.split()[0]: line.split() for line in out.splitlines() if line.startswith(("step ", "lstm-guided "))}
    assert "suite gaps-40: 2 cases" in out and set(rows) == {"step", "lstm-guided"}
    assert all(row[1] in ("0/2", "1/2", "2/2") and float(row[2]) > 0 for row in rows.values()), out
    assert "mean t_plan step / lstm-guided = " in out and "x; step-map calls " in out
    assert rows["step"][1] == rows["lstm-guided"][1] == "2/2", out   # the ratios again over the calls both finished
    assert "over the 2 calls both found a plan: mean t_plan " in out, out
    code, out, err = run_script("planning_speed", "--suites", tmp_path / "s.json", "--planners", "step,angle",
                                "--pairs", "step:angle")
    assert code == 2 and "angle" in err and "profiles" in err and len(err.strip().splitlines()) == 1 and not out
