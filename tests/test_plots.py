"""Figures of results (verification/plots.py, drakeslip.viz.plot_search_tree) from small real inputs, and the
scripts' figure flags refusing bad paths before any work."""
import json

import numpy as np
import pytest

import drakeslip as ds
import planners
from drakeslip.controller import DEFAULT_WEIGHTS
from drakeslip.noise import profile
from planners.closed_loop import ClosedLoopConfig
from planners.formats.plan import PlanRecord
from planners.formats.suite import make_suite, save_suite
from verification import evaluation, plots


def is_png(path) -> bool:
    return path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 10_000


@pytest.fixture(scope="module")
def runs():
    """Two cases of the heuristic and step planners on the fast backend, noiseless and at realistic*0.5."""
    suite = make_suite("ditch", 7, 1, speeds=(2.0, 2.5), heights=(0.9,))
    # the controller named explicitly: drakeslip.jobs.executors.prepare skips a setup this process already ran
    # even when another one ran since (then the planners are not this run's); a setup of its own avoids that
    return [evaluation.evaluate(suite, {"heuristic": {}, "step": {}}, n_cases=2, progress=False,
                               controller_path=str(DEFAULT_WEIGHTS), config=ClosedLoopConfig(backend="fast", noise=profile(f"realistic*{k}")))
            for k in (0, 0.5)]


@pytest.fixture(scope="module")
def record():
    suite = make_suite("ditch", 7, 1, speeds=(2.0,), heights=(0.9,))
    case, params = suite.cases[0], ds.SlipParams(friction=suite.friction)
    plan = planners.make("heuristic").plan(case.apex, case.terrain.perceived(case.apex.x), suite.goal_x, params)
    return PlanRecord.from_plan(plan, case.apex, case.terrain, suite.goal_x, params)


def test_noise_scale_of_a_recorded_profile():
    assert plots.noise_scale(profile("realistic*0.25").to_dict()) == pytest.approx(0.25)
    assert plots.noise_scale(profile("none").to_dict()) == 0.0
    assert plots.noise_scale(profile("state").to_dict()) is None


def test_result_figures(runs, tmp_path):
    from verification.paper import TABLES

    assert is_png(plots.success_figure(runs, tmp_path / "s.png", {"ditch-7": TABLES["ditch"]}))
    assert is_png(plots.cost_figure(runs, tmp_path / "c.png"))
    assert is_png(plots.noise_figure(runs, tmp_path / "n.png"))
    assert set(plots.noise_runs(runs)) == {("ditch-7", "heuristic"), ("ditch-7", "step")}
    with pytest.raises(ValueError, match="two or more noise scales"):
        plots.noise_figure(runs[:1], tmp_path / "none.png")


def test_plot_results_script(runs, tmp_path, run_script):
    files = []
    for i, r in enumerate(runs):
        files.append(tmp_path / f"r{i}.json")
        files[-1].write_text(json.dumps(r))
    code, out, _ = run_script("plot_results", *files, "--out", tmp_path / "figs")
    assert code == 0 and all(is_png(tmp_path / "figs" / f"{n}.png") for n in ("success", "cost", "noise"))
    (tmp_path / "bad.json").write_text('{"suite": "x"}')
    code, _, err = run_script("plot_results", tmp_path / "bad.json", "--out", tmp_path / "figs")
    assert code == 2 and "not a results file" in err and len(err.splitlines()) == 1
    code, _, err = run_script("plot_results", tmp_path / "missing.json")
    assert code == 2 and "no such file" in err


def test_robustness_and_plan_figures(record, tmp_path):
    from verification.plan_check import check_plan
    from verification.robustness import success_probability

    result = success_probability(record, 40, profile("realistic"), seed=1, hops=2)
    document = json.loads(json.dumps(result.to_dict()))
    assert len(document["draws"]["outcome"]) == 40 and np.shape(document["draws"]["apex_errors"]) == (40, 2, 3)
    assert is_png(plots.robustness_figure(document, tmp_path / "r.png", "heuristic plan"))
    check = check_plan(record, "footholds")
    assert check.simulation is not None and check.simulation.times.size
    assert is_png(plots.plan_check_figure(check, record, check.simulation, tmp_path / "v.png"))
    from drakeslip.rollout import rollout

    sim = rollout(record.apex, record.terrain, record.params, footholds=list(record.footholds[:3]),
                  controller=ds.StepLengthController.load_default(), log=True).simulation
    fake = {"seed_footholds": list(record.footholds[:3]), "footholds": list(record.footholds[:3]),
            "apexes": [list(a) for a in record.apexes[:3]], "verified": True}
    assert is_png(plots.trajopt_figure(record.terrain, [{"seed": "heuristic", "record": fake, "seed_sim": sim,
                                                         "drake_sim": sim}], tmp_path / "t.png", "a case"))


def test_search_tree_and_script_flags(tmp_path, run_script):
    suite_path = tmp_path / "suite.json"
    save_suite(make_suite("ditch", 7, 1, speeds=(2.0,), heights=(0.9,)), suite_path)
    code, out, _ = run_script("make_plan", "--suite", suite_path, "--case", "0", "--planner", "step", "--out",
                              tmp_path / "plan.json", "--plot", tmp_path / "tree.png")
    assert code == 0 and is_png(tmp_path / "tree.png")
    for script, args in (("make_plan", ["--suite", suite_path, "--case", "0", "--planner", "step", "--out",
                                        tmp_path / "p.json", "--plot", tmp_path / "t.pdf"]),
                         ("verify_plan", ["--plan", tmp_path / "plan.json", "--plot", tmp_path / "v.jpg"]),
                         ("verify_plan", ["--plan", tmp_path / "plan.json", "--html", tmp_path / "v.htm"]),
                         ("robustness", ["--plan", tmp_path / "plan.json", "--plot", tmp_path / "r.svg"]),
                         ("robustness", ["--plan", tmp_path / "plan.json", "--out", tmp_path / "r.txt"])):
        code, _, err = run_script(script, *args)
        assert code == 2 and "must end in" in err and len(err.splitlines()) == 1, (script, err)
    # Step-space's 10-hop plan for this case runs on Drake as written (every foothold within 1.7 mm): certified
    code, out, _ = run_script("verify_plan", "--plan", tmp_path / "plan.json", "--plot", tmp_path / "v.png",
                              "--html", tmp_path / "v.html")
    assert code == 0 and "CERTIFIED: all 10 hops" in out, out
    assert is_png(tmp_path / "v.png") and (tmp_path / "v.html").stat().st_size > 100_000
