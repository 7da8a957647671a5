"""The model-checking oracle on tiny terrains with known answers, its Drake witnesses, budgets and the CLI."""
import json
import re
from pathlib import Path

import numpy as np
import pytest

from drakeslip import SlipParams, Terrain
from drakeslip.simulation import simulate
from planners.base import Budget
from planners.formats.suite import load_suite, make_suite, save_suite
from drakeslip.jobs.executors import make_executor
from verification import model_check as mc
from verification import model_check_suite as mcs

ROOT = Path(__file__).resolve().parents[1]
PARAMS = SlipParams(friction=0.8)
SMALL = Budget(max_nodes=50_000, max_time_s=30.0)


def terrain(*features):
    """Ground at 0 over [-2, 8) m in 10 cm cells, with (start, end, height) features."""
    h = np.zeros(100)
    for a, b, level in features:
        h[int(round((a + 2) / 0.1)):int(round((b + 2) / 0.1))] = level
    return Terrain(h, 0.1, -2.0)


def test_flat_ground_is_traversable_and_the_witness_rechecks_open_loop_on_drake():
    apex = (0.0, 1.0, 2.0)
    r = mc.model_check(apex, Terrain.flat(), 3.0, PARAMS, budget=SMALL)
    assert r["verdict"] == mc.TRAVERSABLE and r["drake"][-1]["ok"]
    w = r["witness"]
    assert r["hops"] == len(w["leg_angles"]) == len(w["footholds"]) == len(w["apexes"]) >= 2
    assert all(abs(a) < PARAMS.max_leg_angle for a in w["leg_angles"])
    sim = simulate(apex, w["leg_angles"], Terrain.flat(), PARAMS, log=False)
    assert sim.ok and len(sim.apexes) == r["hops"] and sim.apexes[-1].x >= 3.0
    assert [list(a) for a in sim.apexes] == w["apexes"]   # the Drake run the witness came from, exactly


def test_a_drifting_drake_run_is_replanned_and_still_rechecks(monkeypatch):
    monkeypatch.setattr(mc, "REPLAN_TOLERANCE", 0.0)   # every apex differs from the fast map's by ~1e-8
    apex = (0.0, 1.0, 2.0)
    r = mc.model_check(apex, Terrain.flat(), 3.0, PARAMS, budget=SMALL)
    assert r["verdict"] == mc.TRAVERSABLE and r["drake"][-1]["replans"] >= 1 and r["drake"][-1]["drift_hop"] == 1
    sim = simulate(apex, r["witness"]["leg_angles"], Terrain.flat(), PARAMS, log=False)
    assert sim.ok and sim.apexes[-1].x >= 3.0


def test_a_narrow_ditch_is_traversable():
    r = mc.model_check((0.0, 1.0, 1.5), terrain((1.5, 1.8, -1.0)), 3.0, PARAMS, budget=SMALL, drake_check=False)
    assert r["verdict"] == mc.TRAVERSABLE
    assert not any(1.5 <= x < 1.8 for x in r["witness"]["footholds"])


def test_a_three_metre_ditch_is_not_traversable():
    r = mc.model_check((0.0, 1.0, 1.5), terrain((1.5, 4.5, -1.0)), 5.5, PARAMS, levels=(mc.COARSE,), budget=SMALL)
    assert r["verdict"] == mc.NOT_TRAVERSABLE and r["witness"] is None
    assert r["passes"][0]["stop"] == "exhausted" and r["nodes"] > 100


def test_a_step_taller_than_the_energy_allows_is_not_traversable_at_both_resolutions():
    # apex energy reaches 0.9 + 1.5^2 / (2 g) = 1.01 m: a 1.2 m step can be neither landed on nor passed
    r = mc.model_check((0.0, 0.9, 1.5), terrain((1.5, 8.0, 1.2)), 3.0, PARAMS, budget=SMALL)
    assert r["verdict"] == mc.NOT_TRAVERSABLE
    assert [p["angle_deg"] for p in r["passes"]] == [0.5, 0.25]
    assert all(p["stop"] == "exhausted" for p in r["passes"])


def test_a_budget_that_runs_out_gives_unknown():
    r = mc.model_check((0.0, 1.0, 1.5), terrain((1.5, 4.5, -1.0)), 5.5, PARAMS, budget=Budget(100, max_time_s=30.0))
    assert r["verdict"] == mc.UNKNOWN and r["passes"][0]["stop"] == "nodes" and r["nodes"] <= 100


def test_a_start_past_the_goal_is_traversable_with_no_hops():
    assert mc.model_check((5.0, 1.0, 1.0), Terrain.flat(), 3.0, PARAMS)["verdict"] == mc.TRAVERSABLE


def test_bad_inputs_name_the_value():
    suite = make_suite("ditch", 7, 1, speeds=(2.0,), heights=(0.9,))
    with pytest.raises(ValueError, match="unknown case id.*'ditch-9-v2-z0.9'"):
        mcs.select_cases(suite, ids=["ditch-9-v2-z0.9"])
    with pytest.raises(ValueError, match="number of cases.*0"):
        mcs.select_cases(suite, 0)
    with pytest.raises(ValueError, match="max_time_s.*-1"):
        Budget(10, max_time_s=-1)
    with pytest.raises(ValueError, match="angle_deg.*0"):
        mc.Resolution(0, 0.01, 0.01)
    with pytest.raises(ValueError, match="not above the terrain"):
        mc.model_check((0.0, -0.1, 1.0), Terrain.flat(), 3.0, PARAMS)


def test_cross_check_finds_a_crossed_case_called_not_traversable():
    oracle = {"cases": [{"id": "a", "verdict": mc.NOT_TRAVERSABLE}, {"id": "b", "verdict": mc.TRAVERSABLE},
                        {"id": "c", "verdict": mc.UNKNOWN}]}
    evaluation = {"planners": {"step": {"cases": [{"id": "a", "success": True}, {"id": "b", "success": False},
                                                  {"id": "c", "success": True}, {"id": "d", "success": True}]}}}
    assert mcs.cross_check(oracle, evaluation) == {
        "step": {"compared": 3, "crossed": 2, "contradicted": ["a"], "missed": ["b"]}}


def test_random_case_selection_is_seeded():
    suite = make_suite("step", 3, 2)
    a, b = mcs.select_cases(suite, 5, seed=1), mcs.select_cases(suite, 5, seed=1)
    assert [c.id for c in a] == [c.id for c in b] and len({c.id for c in a}) == 5


def test_cli_writes_the_results_format_and_resumes(tmp_path, monkeypatch, run_script):
    suite_path = tmp_path / "suite.json"
    save_suite(make_suite("ditch", 7, 1, speeds=(2.0,), heights=(0.9,)), suite_path)
    out = tmp_path / "oracle.json"
    code, stdout, err = run_script("model_check", "--suite", suite_path, "--cases", "1", "--out", out, "--quiet",
                                   "--budget", "20000", "--seconds", "60")
    assert code == 0, err
    assert "ceiling 100.0 %" in stdout
    results = json.loads(out.read_text())
    assert set(results) >= {"suite", "cases", "summary"}
    assert set(results["summary"]) >= {"traversable", "not_traversable", "unknown", "decided_rate", "ceiling"}
    case = results["cases"][0]
    assert set(case) >= {"id", "verdict", "witness", "nodes", "time_s"} and case["verdict"] == mc.TRAVERSABLE
    # a second run takes every verdict from OUT.cases.jsonl and runs no search
    monkeypatch.setattr(mcs, "model_check", lambda *a, **k: pytest.fail("the cached case was searched again"))
    suite = load_suite(suite_path)
    again = mcs.check_suite(suite, mcs.select_cases(suite, 1), Path(str(out) + ".cases.jsonl"), Budget(20000, max_time_s=60.0),
                           progress=False)
    assert again["cases"] == results["cases"]


def test_two_processes_give_the_verdicts_of_one():
    suite = make_suite("ditch", 7, 1, speeds=(1.5, 2.5), heights=(0.9,))
    runs = [mcs.check_suite(suite, list(suite.cases), None, Budget(20000, max_time_s=60.0), progress=False,
                            executor=make_executor("local", jobs)) for jobs in (1, 2)]
    untimed = lambda d: {k: v for k, v in d.items() if k != "time_s"}
    strip = lambda r: [{**untimed(c), "passes": [untimed(p) for p in c["passes"]]} for c in r["cases"]]
    assert len(runs[0]["cases"]) == 2 and strip(runs[0]) == strip(runs[1])


@pytest.mark.parametrize("args, message", [
    (["--budget", "0"], "--budget: must be an integer in .1, inf., got '0'"),
    (["--seconds", "nan"], "--seconds: must be a finite number > 0.0, got 'nan'"),
    (["--ids", "nope"], "unknown case id"),
    (["--cases", "-3"], "--cases: must be an integer in .1, inf., got '-3'"),
    (["--jobs", "0"], "--jobs: must be an integer in .1, inf., got '0'"),
    (["--suite-edit"], r"cases\[0\]\.apex.*'z'"),
])
def test_cli_errors_name_the_bad_value(tmp_path, capsys, args, message, example):
    doc = make_suite("ditch", 7, 1, speeds=(2.0,), heights=(0.9,)).to_dict()
    if args == ["--suite-edit"]:
        doc["cases"][0]["apex"].pop("z")
        args = []
    suite_path = tmp_path / "suite.json"
    suite_path.write_text(json.dumps(doc))
    with pytest.raises(SystemExit) as stop:
        example("model_check").main(["--suite", str(suite_path), "--out", str(tmp_path / "o.json"), *args])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert re.search(message, err) and len(err.splitlines()) == 1
    assert not (tmp_path / "o.json").exists()
