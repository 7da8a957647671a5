"""Suites and the receding-horizon evaluation, end to end on the Drake simulator."""
import json
import subprocess
import sys
from pathlib import Path

import pytest

import planners
from drakeslip.jobs.executors import make_executor
from planners.closed_loop import ClosedLoopConfig
from planners.formats.suite import load_suite, make_suite, save_suite
from planners.registry import PRESETS, make_planners
from verification import evaluation, report
from verification.provenance import code_version

ROOT = Path(__file__).resolve().parents[1]


def _doc():
    return make_suite("ditch", seed=7, n_terrains=1, speeds=(2.0,), heights=(0.9,)).to_dict()


def test_suite_round_trip(tmp_path):
    suite = make_suite("step", seed=3, n_terrains=2)
    assert len(suite.cases) == 20 and suite.friction == 0.8 and suite.goal_x == 10.0
    save_suite(suite, tmp_path / "s.json")
    again = load_suite(tmp_path / "s.json")
    assert again.to_dict() == suite.to_dict()


@pytest.mark.parametrize("edit, field", [
    (lambda d: d.pop("format"), "format"),
    (lambda d: d.update(format="drakeslip-suite/0"), "format"),
    (lambda d: d.update(goal_x="far"), "goal_x"),
    (lambda d: d.update(friction=-1), "friction"),
    (lambda d: d.update(cases=[]), "cases"),
    (lambda d: d["cases"][0].pop("id"), r"cases\[0\].*'id'"),
    (lambda d: d["cases"][0]["apex"].pop("z"), r"cases\[0\]\.apex.*'z'"),
    (lambda d: d["cases"][0]["apex"].update(xdot=float("nan")), r"cases\[0\]\.apex\.xdot"),
    (lambda d: d["cases"][0]["apex"].update(z=-2.0), r"cases\[0\]\.apex\.z"),
    (lambda d: d["cases"][0]["terrain"]["heights"].__setitem__(5, "x"), r"cases\[0\]\.terrain\.heights\[5\]"),
    (lambda d: d["cases"][0]["terrain"].update(cell=0), r"cases\[0\]\.terrain\.cell"),
])
def test_malformed_suite_names_the_field(tmp_path, edit, field):
    doc = _doc()
    edit(doc)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match=field):
        load_suite(path)


def test_suite_that_is_not_json(tmp_path):
    path = tmp_path / "broken.json"
    path.write_text("{")
    with pytest.raises(ValueError, match="broken.json.*not valid JSON"):
        load_suite(path)


@pytest.mark.slow  # an end-to-end run of the script in a fresh interpreter
def test_evaluate_cli_writes_the_results_format_and_resumes(tmp_path):
    suite_path = tmp_path / "suite.json"
    save_suite(make_suite("ditch", 7, 1, speeds=(2.0, 2.5), heights=(0.9,)), suite_path)
    out = tmp_path / "results.json"
    cmd = [sys.executable, str(ROOT / "examples" / "evaluate.py"), "--suite", str(suite_path), "--planners",
           "heuristic,step", "--cases", "2", "--out", str(out), "--quiet"]
    run = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert run.returncode == 0, run.stderr
    assert "Success %" in run.stdout and "step" in run.stdout
    results = json.loads(out.read_text())
    assert set(results) == {"suite", "hopper", "options", "planners", "provenance"}
    assert results["hopper"]["params"]["mass"] == 7.0     # the suite's hopper: the paper's, as planned for
    assert set(results["planners"]) == {"heuristic", "step"}
    for block in results["planners"].values():
        assert block["config"] == ClosedLoopConfig().to_dict()   # the protocol: noiseless, the paper's period
        assert set(block) == {"config", "weights", "success_rate", "success_interval", "ode_calls_mean", "ode_calls_median",
                              "t_plan_mean_s", "t_plan_median_s", "nodes_expanded_mean", "footholds_mean",
                              "time_limited_calls", "timing_mean_s", "cases"}
        assert block["success_interval"][0] <= block["success_rate"] <= block["success_interval"][1]
        assert len(block["cases"]) == 2
        for case in block["cases"]:
            assert set(case) == {"id", "success", "failure", "final_x", "plans"}
            assert case["success"] == (case["failure"] is None)
            assert all({"ode_calls", "t_plan_s"} <= set(p) for p in case["plans"])
    # the case cache lets a second run finish without running any case again
    cache = Path(str(out) + ".cases.jsonl")
    assert len(cache.read_text().splitlines()) == 4
    with cache.open("a") as f:
        f.write('{"key": "cut sh')  # a line cut short by a kill is ignored
    again = evaluation.evaluate(load_suite(suite_path), {"heuristic": {}, "step": {}}, n_cases=2, cache_path=cache,
                               progress=False, config=ClosedLoopConfig())
    assert {**again, "provenance": None} == {**results, "provenance": None}  # all but the date and machine


def test_results_say_where_they_came_from():
    """Two runs of different settings can be told apart from their results alone: the closed-loop config (noise,
    period, backend), the options after presets, the weights' digests and the code, libraries and machine."""
    suite = make_suite("ditch", 7, 1, speeds=(2.0,), heights=(0.9,))
    from drakeslip.noise import profile

    runs = [evaluation.evaluate(suite, {"heuristic": {}}, n_cases=1, progress=False, config=config)
            for config in (ClosedLoopConfig(backend="fast"),
                           ClosedLoopConfig(backend="fast", executed_per_plan=1, noise=profile("realistic*0.5")))]
    quiet, noisy = (r["planners"]["heuristic"]["config"] for r in runs)
    assert quiet["noise"]["leg_angle"] == 0 and noisy["noise"]["leg_angle"] == pytest.approx(
        0.5 * profile("realistic").leg_angle)
    assert (quiet["executed_per_plan"], noisy["executed_per_plan"]) == (3, 1) and quiet["backend"] == "fast"
    p = runs[0]["provenance"]
    assert set(p) == {"package_version", "code_version", "git_commit", "git_dirty", "versions", "cores", "date",
                      "platform"}
    assert set(p["versions"]) == {"python", "drake", "torch", "numpy"} and p["versions"]["numpy"]
    assert p["cores"] >= 1 and p["date"].endswith("+00:00")
    weights = runs[0]["planners"]["heuristic"]["weights"]
    assert weights == {"drakeslip/weights/controller.pt": evaluation.weights_files("heuristic", {})[
        "drakeslip/weights/controller.pt"]} and len(next(iter(weights.values()))) == 64
    lstm = evaluation.weights_files("lstm", None)
    assert len(lstm) >= 2 and all(len(v) == 64 for v in lstm.values())  # the model's files too


def test_every_kth_case_is_evaluated(tmp_path):
    suite = make_suite("ditch", 7, 1, speeds=(2.0, 2.5), heights=(0.8, 0.9))
    results = evaluation.evaluate(suite, {"heuristic": {}}, n_cases=2, every=3, progress=False,
                                  config=ClosedLoopConfig(backend="fast"))
    assert [c["id"] for c in results["planners"]["heuristic"]["cases"]] == [suite.cases[0].id, suite.cases[3].id]
    with pytest.raises(ValueError, match="every must be a positive integer, got 0"):
        evaluation.evaluate(suite, {"heuristic": {}}, every=0, progress=False)


def test_ratios_to_a_baseline_per_planning_call():
    def case(ode, t, found):
        return {"id": "c", "success": all(found), "failure": None, "final_x": 0.0,
                "plans": [{"ode_calls": o, "t_plan_s": s, "success": f, "nodes_expanded": o // 10,
                           "footholds": [1.0] * (o // 50 if f else 0)} for o, s, f in zip(ode, t, found)]}
    results = {"suite": "s", "planners": {
        "step": report.summarize([case([100, 300], [1.0, 9.0], [True, False])]),
        "guided": report.summarize([case([50, 50], [0.5, 3.0], [True, False])])}}
    # nodes expanded per call, and footholds per plan over the calls that found one
    assert (results["planners"]["step"]["nodes_expanded_mean"], results["planners"]["step"]["footholds_mean"]) == (20, 2)
    assert "guided" in report.table(results).splitlines()[-1].split()[0]
    row = report.ratios(results, "step").splitlines()[-1].split()
    # ODE mean and median 200/50; time mean 5/1.75; over the calls that found a plan 1/0.5; median 5/1.75
    assert row == ["guided", "4.00x", "4.00x", "2.86x", "2.00x", "2.86x"]
    with pytest.raises(ValueError, match="baseline 'angle' is not among"):
        report.ratios(results, "angle")


def test_unknown_planner_on_the_cli(tmp_path, run_script):
    code, _, err = run_script("evaluate", "--suite", ROOT / "suites/step.json", "--planners", "warp", "--out",
                              tmp_path / "o.json")
    assert code == 2 and "unknown planner 'warp'" in err
    code, _, err = run_script("evaluate", "--suite", ROOT / "suites/step.json", "--planners", "step", "--baseline",
                              "angle", "--out", tmp_path / "o.json")
    assert code == 2 and "--baseline 'angle' is not among --planners ['step']" in err


@pytest.mark.parametrize("options, message", [
    ('{"step": {"bogus": 1}}', "--options for step: Planner.__init__() got an unexpected keyword argument 'bogus'"),
    ('{"step": {"spacing": -1}}', "--options for step: spacing must be a positive distance, got -1"),
    ("{step", "--options is not valid JSON"),
    ('{"step": 3}', "--options must map planner labels among ['step'] to option objects"),
])
def test_bad_planner_options_on_the_cli_are_named_before_any_case_runs(tmp_path, run_script, options, message):
    code, _, err = run_script("evaluate", "--suite", ROOT / "suites/step.json", "--planners", "step", "--options",
                              options, "--out", tmp_path / "o.json")
    assert code == 2 and message in err and len(err.splitlines()) == 1
    assert not (tmp_path / "o.json").exists()


@pytest.mark.parametrize("script, args", [("evaluate", ["--planners", "step", "--out", "o.json"]),
                                           ("paper_tables", ["--planners", "step", "--step", "suites/step.json",
                                                             "--out", "."])])
@pytest.mark.parametrize("text, message", [
    ('{"format": "drakeslip-suite/1", "cases": 3', "is not valid JSON"),
    ("[1, 2]", "must be an object, got list"),
])
def test_a_malformed_suite_file_is_named_on_the_cli(tmp_path, run_script, script, args, text, message):
    (tmp_path / "bad.json").write_text(text)
    flag = "--ditch" if script == "paper_tables" else "--suite"
    code, _, err = run_script(script, flag, tmp_path / "bad.json",
                              *[ROOT / a if a.startswith("suites/") else tmp_path / a if a in ("o.json", ".") else a
                                for a in args])
    assert code == 2 and f"suite file {tmp_path / 'bad.json'}" in err and message in err
    assert len(err.splitlines()) == 1 and not (tmp_path / "o.json").exists()


def test_evaluate_refuses_a_bad_planner_option_by_label_before_any_case(tmp_path):
    suite = make_suite("ditch", seed=7, n_terrains=1)
    cache = tmp_path / "cache.jsonl"
    for jobs in (1, 2):
        with pytest.raises(ValueError, match=r"options for step@fine: .*spacing must be a positive distance"):
            evaluation.evaluate(suite, {"step": {}, "step@fine": {"spacing": 0.0}}, n_cases=1,
                               executor=make_executor("local", jobs), cache_path=cache, progress=False)
        assert not cache.exists()


def test_two_settings_of_one_planner_run_side_by_side(tmp_path):
    """NAME@VARIANT labels: the same planner with other options, each with its own results and cache key."""
    suite_path = tmp_path / "suite.json"
    suite_path.write_text(json.dumps(_doc()))
    specs = {"heuristic": {}, "heuristic@noshift": {"max_shift": 0.0}}
    results = evaluation.evaluate(load_suite(suite_path), specs, n_cases=1, progress=False,
                                  config=ClosedLoopConfig(backend="fast"))
    assert set(results["planners"]) == {"heuristic", "heuristic@noshift"}
    assert planners.planner_name("heuristic@noshift") == "heuristic"
    suite = load_suite(suite_path)
    keys = {evaluation.fingerprint(suite, label, opts, ClosedLoopConfig(), None) for label, opts in specs.items()}
    assert len(keys) == 2
    assert "heuristic@noshift" in report.table(results)


def test_defaults_are_the_best_settings_and_the_papers_are_presets():
    built = make_planners({"lstm": {}, "lstm-guided": {}, "lstm@paper": {}, "lstm-guided@paper": {},
                           "lstm@other": {"top_k": 3}})
    assert built["lstm"].ranker is not None and built["lstm"].max_steps == 1
    assert built["lstm-guided"].lazy and built["lstm-guided"].conditioning == "apex"
    assert built["lstm@paper"].ranker is None and built["lstm@paper"].max_steps == 12
    assert not built["lstm-guided@paper"].lazy and built["lstm-guided@paper"].conditioning == "path"
    assert built["lstm@other"].ranker is not None  # not a preset: the planner's defaults and its own options
    # a variant that is no preset and has no options would run the plain planner under another name: a typo
    with pytest.raises(ValueError, match=r"'lstm@papr' is no preset .* takes its options from --options"):
        make_planners({"lstm@papr": {}})
    # options given for a preset label update the preset
    updated = make_planners({"lstm@paper": {"max_steps": 2}})["lstm@paper"]
    assert updated.max_steps == 2 and updated.ranker is None
    suite = make_suite("ditch", seed=7, n_terrains=1)
    results = evaluation.evaluate(suite, {"lstm@no-ranker": {}}, n_cases=1, progress=False,
                                 config=ClosedLoopConfig(backend="fast"))
    explicit = evaluation.evaluate(suite, {"lstm@no-ranker": PRESETS["lstm@no-ranker"]}, n_cases=1, progress=False,
                                  config=ClosedLoopConfig(backend="fast"))
    strip = lambda r: [[p["footholds"] for p in c["plans"]] for c in r["planners"]["lstm@no-ranker"]["cases"]]
    assert strip(results) == strip(explicit)


def test_the_cache_key_follows_every_weights_file_an_option_names(tmp_path):
    """Retraining the ranker at the same path must not reuse cached cases (nor may the LSTM model)."""
    from planners.checkpoints import RANKER_WEIGHTS

    suite = make_suite("ditch", seed=7, n_terrains=1)
    ranker = tmp_path / "ranker.pt"
    ranker.write_bytes(RANKER_WEIGHTS.read_bytes())
    key = lambda: evaluation.fingerprint(suite, "lstm@r", {"ranker": str(ranker)}, ClosedLoopConfig(), None)
    before = key()
    assert key() == before
    ranker.write_bytes(RANKER_WEIGHTS.read_bytes() + b"retrained")
    assert key() != before


def test_the_cache_key_follows_the_checkpoint_a_trajopt_seed_reads(tmp_path):
    """The trajectory optimizer as a planner reads its seed planner's LSTM: retraining it invalidates cached cases."""
    from planners.checkpoints import PAPER_WEIGHTS

    suite = make_suite("ditch", seed=7, n_terrains=1)
    lstm = tmp_path / "lstm.pt"
    lstm.write_bytes(PAPER_WEIGHTS.read_bytes())
    options = {"seed": "lstm-guided@x", "seed_options": {"model": str(lstm)}}
    key = lambda: evaluation.fingerprint(suite, "trajopt", options, ClosedLoopConfig(), None)
    before = key()
    assert key() == before
    lstm.write_bytes(PAPER_WEIGHTS.read_bytes() + b"retrained")
    assert key() != before
    step_seed = lambda: evaluation.fingerprint(suite, "trajopt", {"seed": "step"}, ClosedLoopConfig(), None)
    assert step_seed() == step_seed() != before


def test_cost_weights_given_as_options_are_part_of_the_cache_key():
    """Angle- and Step-space take ``cost_weights`` (a list, not a file): the list is keyed as given."""
    suite = make_suite("ditch", seed=7, n_terrains=1)
    key = lambda w: evaluation.fingerprint(suite, "step@w", {"cost_weights": w}, ClosedLoopConfig(), None)
    assert key([1, 0, 2]) == key([1, 0, 2]) != key([1, 1, 2])


def test_resuming_after_a_code_change_runs_the_cases_again(tmp_path, monkeypatch, capsys):
    """Cached cases are reused by the same code only: the results file's provenance names the code version its
    per-case results were computed with, and another version ignores them (and says how many)."""
    suite = make_suite("ditch", 7, 1, speeds=(2.0, 2.5), heights=(0.9,))
    cache, config = tmp_path / "cache.jsonl", ClosedLoopConfig(backend="fast")
    first = evaluation.evaluate(suite, {"heuristic": {}}, cache_path=cache, progress=False, config=config)
    assert first["provenance"]["code_version"] == code_version()
    again = evaluation.evaluate(suite, {"heuristic": {}}, cache_path=cache, progress=False, config=config)
    assert f"cache {cache}: 2 of 2 results reused\n" in capsys.readouterr().out
    assert again["planners"] == first["planners"]
    real = evaluation.provenance
    monkeypatch.setattr(evaluation, "provenance", lambda: {**real(), "code_version": "git:other"})
    changed = evaluation.evaluate(suite, {"heuristic": {}}, cache_path=cache, progress=False, config=config)
    assert f"cache {cache}: 0 of 2 results reused; 2 made by other code ignored\n" in capsys.readouterr().out
    assert changed["provenance"]["code_version"] == "git:other"
    assert len(cache.read_text().splitlines()) == 4   # the cases ran again, each line stamped with its code
    assert [json.loads(line)["stamp"] for line in cache.read_text().splitlines()] == [code_version()] * 2 + [
        "git:other"] * 2


def test_the_code_version_follows_commits_uncommitted_changes_and_new_files(tmp_path, monkeypatch):
    """``code_version`` of a checkout: the commit, plus a digest of uncommitted changes to tracked files and of
    new files in the packages (not of outputs elsewhere); outside git, a digest of the packages' files."""
    from verification import provenance

    package = tmp_path / "drakeslip"
    package.mkdir()
    (package / "a.py").write_text("A = 1\n")
    monkeypatch.setattr(provenance, "ROOT", tmp_path)
    git = lambda *args: subprocess.run(["git", "-c", "user.name=t", "-c", "user.email=t@t", *args], cwd=tmp_path,
                                       check=True, capture_output=True)
    git("init", "-q")
    git("add", ".")
    git("commit", "-qm", "one")
    commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=tmp_path, capture_output=True, text=True).stdout.strip()
    assert provenance.code_version() == f"git:{commit}"
    (tmp_path / "out.json").write_text("{}")   # an output: not code
    assert provenance.code_version() == f"git:{commit}"
    (package / "a.py").write_text("A = 2\n")
    edited = provenance.code_version()
    (package / "a.py").write_text("A = 3\n")
    assert edited.startswith(f"git:{commit}+") and provenance.code_version() not in (edited, f"git:{commit}")
    (package / "a.py").write_text("A = 1\n")
    (package / "b.py").write_text("B = 1\n")   # a new module of the package
    assert provenance.code_version().startswith(f"git:{commit}+")
    subprocess.run(["rm", "-rf", str(tmp_path / ".git")], check=True)
    source = provenance.code_version()
    assert source.startswith("source:") and provenance.provenance(source)["git_commit"] is None
    (package / "b.py").write_text("B = 2\n")
    assert provenance.code_version() != source
