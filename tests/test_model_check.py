"""The model-checking oracle on tiny terrains with known answers, its Drake witnesses, budgets, what its verdicts
say, a refinement of its grid verdicts (finer angles, no merging) and the CLI."""
import math
import json
import re
from pathlib import Path

import numpy as np
import pytest

from drakeslip import SlipParams, Terrain, step_batch
from drakeslip.simulation import simulate
from planners.base import Budget
from planners.formats.suite import load_suite, make_suite, save_suite
from drakeslip.jobs.executors import make_executor
from verification import drake_witness
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
    monkeypatch.setattr(drake_witness, "REPLAN_TOLERANCE", 0.0)   # every apex differs from the fast map's by ~1e-8
    apex = (0.0, 1.0, 2.0)
    r = mc.model_check(apex, Terrain.flat(), 3.0, PARAMS, budget=SMALL)
    assert r["verdict"] == mc.TRAVERSABLE and r["drake"][-1]["replans"] >= 1 and r["drake"][-1]["drift_hop"] == 1
    sim = simulate(apex, r["witness"]["leg_angles"], Terrain.flat(), PARAMS, log=False)
    assert sim.ok and sim.apexes[-1].x >= 3.0


def test_a_narrow_ditch_is_traversable():
    r = mc.model_check((0.0, 1.0, 1.5), terrain((1.5, 1.8, -1.0)), 3.0, PARAMS, budget=SMALL, drake_check=False)
    assert r["verdict"] == mc.TRAVERSABLE
    assert not any(1.5 <= x < 1.8 for x in r["witness"]["footholds"])


def test_a_three_metre_ditch_is_proved_not_traversable_and_the_search_agrees():
    ditch = terrain((1.5, 4.5, -1.0))
    r = mc.model_check((0.0, 1.0, 1.5), ditch, 5.5, PARAMS, levels=(mc.COARSE,), budget=SMALL)
    assert r["verdict"] == mc.PROVED_NOT_TRAVERSABLE and r["nodes"] == 0 and r["witness"] is None
    assert r["proof"]["proof"] == "energy" and r["statement"].startswith("proved: ")
    r = mc.model_check((0.0, 1.0, 1.5), ditch, 5.5, PARAMS, levels=(mc.COARSE,), budget=SMALL, energy=False)
    assert r["verdict"] == mc.NOT_TRAVERSABLE and r["witness"] is None and r["proof"] is None
    assert r["passes"][0]["stop"] == "exhausted" and r["nodes"] > 100
    assert r["holds_at"] == {"angle_deg": 0.5, "merge_x": 0.01, "merge_xdot": 0.01, "min_speed": mc.MIN_SPEED,
                             "coarser": []}
    assert "0.5 deg / 1 cm x 1 cm/s (apexes >= 0.1 m/s)" in r["statement"]


def test_a_step_taller_than_the_energy_allows_is_proved_and_not_traversable_at_both_resolutions():
    # apex energy reaches 0.9 + 1.5^2 / (2 g) = 1.01 m: a 1.2 m step can be neither landed on nor passed
    step = terrain((1.5, 8.0, 1.2))
    proved = mc.model_check((0.0, 0.9, 1.5), step, 3.0, PARAMS, budget=SMALL)
    assert proved["verdict"] == mc.PROVED_NOT_TRAVERSABLE and "never be as high" in proved["statement"]
    r = mc.model_check((0.0, 0.9, 1.5), step, 3.0, PARAMS, budget=SMALL, energy=False)
    assert r["verdict"] == mc.NOT_TRAVERSABLE
    assert [p["angle_deg"] for p in r["passes"]] == [0.5, 0.25]
    assert all(p["stop"] == "exhausted" for p in r["passes"])
    assert r["holds_at"]["angle_deg"] == 0.25 and r["holds_at"]["merge_x"] == 0.005
    assert r["holds_at"]["coarser"] == [{"angle_deg": 0.5, "merge_x": 0.01, "merge_xdot": 0.01}]
    assert "unconfirmed" not in r["holds_at"] and "then 0.25 deg / 0.5 cm x 1 cm/s" in r["statement"]


def test_a_budget_that_runs_out_gives_unknown():
    r = mc.model_check((0.0, 1.0, 1.5), terrain((1.5, 4.5, -1.0)), 5.5, PARAMS, budget=Budget(100, max_time_s=30.0),
                       energy=False)
    assert r["verdict"] == mc.UNKNOWN and r["passes"][0]["stop"] == "nodes" and r["nodes"] <= 100
    assert r["why"] == "nodes" and "0.5 deg pass ran out of nodes after" in r["statement"]


def test_a_finer_pass_that_runs_out_leaves_the_coarse_verdict_unconfirmed_or_with_confirm_unknown():
    step = terrain((1.5, 8.0, 1.2))
    coarse = mc.model_check((0.0, 0.9, 1.5), step, 3.0, PARAMS, levels=(mc.COARSE,), budget=SMALL, energy=False)
    budget = Budget(coarse["nodes"] + 10, max_time_s=30.0)   # the 0.25 deg pass gets 10 nodes
    r = mc.model_check((0.0, 0.9, 1.5), step, 3.0, PARAMS, budget=budget, energy=False)
    assert r["verdict"] == mc.NOT_TRAVERSABLE and r["holds_at"]["angle_deg"] == 0.5
    assert r["holds_at"]["unconfirmed"] == {"angle_deg": 0.25, "stop": "nodes", "nodes": 10}
    assert "the 0.25 deg pass ran out of nodes after 10 nodes" in r["statement"]
    strict = mc.model_check((0.0, 0.9, 1.5), step, 3.0, PARAMS, budget=budget, energy=False, confirm=True)
    assert strict["verdict"] == mc.UNKNOWN and strict["why"] == "nodes"
    assert "no plan at 0.5 deg (exhausted)" in strict["statement"]


def refine(apex, ground, goal_x, step_deg=0.1, max_hops=12):
    """Every sequence of leg angles on a ``step_deg`` grid, no merging and no speed floor, ``max_hops`` deep:
    the hop at which no apex is left (the tree is exhausted), or None. Fails if any sequence reaches the goal."""
    k = math.ceil(PARAMS.max_leg_angle / math.radians(step_deg)) - 1
    grid = np.arange(-k, k + 1) * math.radians(step_deg)
    frontier = np.array([apex], dtype=float)
    for hop in range(1, max_hops + 1):
        r = step_batch(np.repeat(frontier, grid.size, axis=0), np.tile(grid, len(frontier)), ground, PARAMS)
        assert not np.any(r.ok & (r.next_x >= goal_x)), f"a refined sequence of {hop} hops reaches the goal"
        frontier = np.column_stack([r.next_x, r.next_z, r.next_xdot])[r.ok]
        if len(frontier) == 0:
            return hop
    return None


@pytest.mark.parametrize("apex, features, goal_x, hops", [
    ((1.0, 1.0, 1.5), [(1.5, 3.4, -1.0)], 4.0, 2),    # a 1.9 m ditch, within the energy bound's 2.1 m reach
    ((0.9, 0.9, 1.5), [(1.5, 8.0, 0.55)], 3.0, 10),   # a 0.55 m step, below the 0.63 m landing ceiling
    ((1.0, 0.8, 1.5), [(1.5, 8.0, 0.45)], 3.0, 1),    # a 0.45 m step from a lower start (ceiling 0.53 m)
])
def test_grid_verdicts_refine_to_no_traversal_on_a_finer_grid_without_merging(apex, features, goal_x, hops):
    ground = terrain(*features)
    r = mc.model_check(apex, ground, goal_x, PARAMS, budget=SMALL, drake_check=False)
    assert r["verdict"] == mc.NOT_TRAVERSABLE and r["holds_at"]["angle_deg"] == 0.25   # not proved: a grid verdict
    assert refine(apex, ground, goal_x) == hops   # 0.1 deg, every apex kept: the tree dies out, no goal on the way


def test_parallel_steps_give_the_same_search():
    args = ((0.0, 1.0, 1.5), terrain((1.5, 1.8, -1.0)), 3.0, PARAMS)
    one, all_cores = (mc.model_check(*args, budget=SMALL, drake_check=False, parallel=p) for p in (False, True))
    assert one["witness"] == all_cores["witness"] and one["nodes"] == all_cores["nodes"]


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


def test_cross_check_finds_a_crossed_case_proved_not_traversable_and_lists_off_grid_plans():
    oracle = {"cases": [{"id": "a", "verdict": mc.NOT_TRAVERSABLE}, {"id": "b", "verdict": mc.TRAVERSABLE},
                        {"id": "c", "verdict": mc.UNKNOWN}, {"id": "e", "verdict": mc.PROVED_NOT_TRAVERSABLE}]}
    evaluation = {"planners": {"step": {"cases": [{"id": "a", "success": True}, {"id": "b", "success": False},
                                                  {"id": "c", "success": True}, {"id": "d", "success": True},
                                                  {"id": "e", "success": True}]}}}
    assert mcs.cross_check(oracle, evaluation) == {
        "step": {"compared": 4, "crossed": 3, "contradicted": ["e"], "off_grid": ["a"], "missed": ["b"]}}


def test_the_summary_counts_proved_and_grid_verdicts_as_not_traversable():
    holds = {"angle_deg": 0.25, "merge_x": 0.005, "merge_xdot": 0.01, "min_speed": 0.1,
             "coarser": [{"angle_deg": 0.5, "merge_x": 0.01, "merge_xdot": 0.01}]}
    records = [{"verdict": mc.TRAVERSABLE, "time_s": 1.0}, {"verdict": mc.PROVED_NOT_TRAVERSABLE, "time_s": 0.0},
               {"verdict": mc.NOT_TRAVERSABLE, "holds_at": holds, "time_s": 9.0},
               {"verdict": mc.UNKNOWN, "why": "time", "time_s": 120.0}]
    s = mcs.summarize(records)
    assert (s["traversable"], s["not_traversable"], s["proved_not_traversable"], s["not_traversable_grid"],
            s["unknown"]) == (1, 2, 1, 1, 1)
    assert s["ceiling"] == 0.25 and s["ceiling_upper"] == 0.5 and s["unknown_why"] == {"time": 1}
    assert s["grid_holds_at"] == {"0.5 deg / 1 cm x 1 cm/s, then 0.25 deg / 0.5 cm x 1 cm/s (apexes >= 0.1 m/s)": 1}


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
    assert set(results) >= {"suite", "cases", "summary", "provenance"}
    assert results["budget"] == {"max_nodes": 20000, "max_time_s": 60.0} and results["provenance"]["versions"]["drake"]
    assert set(results["summary"]) >= {"traversable", "not_traversable", "unknown", "decided_rate", "ceiling"}
    case = results["cases"][0]
    assert set(case) >= {"id", "verdict", "witness", "nodes", "time_s"} and case["verdict"] == mc.TRAVERSABLE
    # a second run takes every verdict from OUT.cases.jsonl and runs no search
    monkeypatch.setattr(mcs, "model_check", lambda *a, **k: pytest.fail("the cached case was searched again"))
    suite = load_suite(suite_path)
    again = mcs.check_suite(suite, mcs.select_cases(suite, 1), Path(str(out) + ".cases.jsonl"), Budget(20000, max_time_s=60.0),
                           progress=False)
    assert again["cases"] == results["cases"]


@pytest.mark.slow  # spawns worker processes that import and compile everything
def test_two_processes_give_the_verdicts_of_one():
    suite = make_suite("ditch", 7, 1, speeds=(1.5, 2.5), heights=(0.9,))
    runs = [mcs.check_suite(suite, list(suite.cases), None, Budget(20000, max_time_s=60.0), progress=False,
                            executor=make_executor("local", jobs)) for jobs in (1, 2)]
    untimed = lambda d: {k: v for k, v in d.items() if k != "time_s"}
    strip = lambda r: [{**untimed(c), "passes": [untimed(p) for p in c["passes"]]} for c in r["cases"]]
    assert len(runs[0]["cases"]) == 2 and strip(runs[0]) == strip(runs[1])


@pytest.mark.parametrize("args, message", [
    (["--budget", "0"], "--budget: must be an integer in .1, 10000000., got '0'"),
    (["--budget", "20000000"], "--budget: must be an integer in .1, 10000000., got '20000000'"),
    (["--seconds", "nan"], "--seconds: must be a finite number > 0.0, got 'nan'"),
    (["--ids", "nope"], "unknown case id"),
    (["--cases", "-3"], "--cases: must be an integer in .1, inf., got '-3'"),
    (["--jobs", "0"], "--jobs: must be an integer in .1, inf., got '0'"),
    (["--suite-edit"], r"cases\[0\]\.apex.*'z'"),
    (["--parallel-steps", "--jobs", "2"], "--parallel-steps uses every core for one case"),
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


def test_a_verdict_cached_by_other_code_or_damaged_is_checked_again(tmp_path, monkeypatch):
    """The cache holds a verdict for the code that made it (``code_version``): another code's is not reused, and a
    line that is not a verdict (a field missing or of the wrong type) is skipped with a warning and run again."""
    suite = make_suite("ditch", 7, 1, speeds=(2.0,), heights=(0.9,))
    cases, cache, budget = mcs.select_cases(suite, 1), tmp_path / "o.json.cases.jsonl", Budget(20000, max_time_s=60.0)
    first = mcs.check_suite(suite, cases, cache, budget, progress=False, code="git:one")
    calls = []
    real = mcs.model_check
    monkeypatch.setattr(mcs, "model_check", lambda *a, **k: calls.append(1) or real(*a, **k))
    assert mcs.check_suite(suite, cases, cache, budget, progress=False, code="git:one")["cases"] == first["cases"]
    assert calls == []
    mcs.check_suite(suite, cases, cache, budget, progress=False, code="git:two")
    assert calls == [1]
    lines = cache.read_text().splitlines()
    damaged = json.loads(lines[-1])
    damaged["result"]["budget"] = {"max_nodes": "many"}
    cache.write_text("\n".join([*lines[:-1], json.dumps(damaged)]) + "\n")
    again = mcs.check_suite(suite, cases, cache, budget, progress=False, code="git:two")
    assert calls == [1, 1] and again["cases"][0]["verdict"] == first["cases"][0]["verdict"]


@pytest.mark.parametrize("change, message", [
    ({"verdict": "maybe"}, "verdict must be one of"), ({"time_s": "1"}, "time_s must be a number"),
    ({"holds_at": [1]}, "holds_at must be null or an object"), ({"budget": {"max_nodes": 1}}, "budget must be"),
])
def test_a_cached_verdict_of_the_wrong_shape_is_named(change, message):
    record = {"verdict": mc.TRAVERSABLE, "time_s": 1.0, "holds_at": None,
              "budget": {"max_nodes": 10, "max_time_s": 1.0}}
    mcs.check_verdict_record(record)
    with pytest.raises(ValueError, match=message):
        mcs.check_verdict_record({**record, **change})
