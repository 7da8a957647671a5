"""Your hopper, your terrain, from the scripts: --hopper and --terrain read up front (a bad one exits 2 in one line
naming the field or row), plan files record their hopper and a plan checked against another hopper is refused,
a hopper folder's weights replace the committed ones in the planners that read them, the paper's hopper keeps the
paper's case, hop.py runs another hopper on a terrain file, the controller lands the targets of the softest,
smallest hopper of the range, and (slow) a terrain file goes through plan_and_hop, make_plan, verify_plan and the replay for a
12 kg, 0.7 m hopper; train_hopper.py at a tiny size writes a hopper folder the planners then use."""
import json
from pathlib import Path

import numpy as np
import pytest

from drakeslip import SlipParams, TERRAIN_FAMILIES
from drakeslip.hopper_file import NamedHopper, hopper_for, load_hopper, make_hopper_folder, paper_hopper, save_hopper
from drakeslip.jobs.files import MANIFEST, record_digest
from planners.checkpoints import EXPERT_WEIGHTS, RANKER_WEIGHTS, SPATIAL_WEIGHTS, SUBCELL_WEIGHTS
from planners.formats.plan import PlanRecord, load_plan, save_plan
from planners.formats.suite_draw import draw_suite, hopper_for_suite, one_case
from planners.registry import files_read, hopper_options, make_planners
from verification.plan_check import check_plan

ROOT = Path(__file__).resolve().parents[1]
BIG = NamedHopper(SlipParams(mass=12.0, leg_length=0.7, stiffness=6000.0), "big")
PROFILE = "x,height\n" + "".join(f"{x / 10:.1f},{'' if 60 <= x < 65 else (0.1 if 90 <= x < 120 else 0.0)}\n"
                                 for x in range(-30, 300))


@pytest.fixture
def inputs(tmp_path):
    """A hopper file for BIG, a profile with a gap and a step, and malformed files; returns their paths."""
    save_hopper(BIG, tmp_path / "big.json")
    (tmp_path / "ground.csv").write_text(PROFILE)
    (tmp_path / "bad-row.csv").write_text("x,height\n0,0\n0.1,abc\n")
    (tmp_path / "bad-mass.json").write_text(json.dumps({"mass": -3, "leg_length": 0.7, "stiffness": 6000}))
    (tmp_path / "no-stiffness.toml").write_text("mass = 12\nleg_length = 0.7\n")
    return tmp_path


HOPPER_PROBES = [   # (script, arguments before --hopper/--terrain)
    ("plan_and_hop", []),
    ("make_plan", ["--suite", "suites/step.json", "--case", "0", "--planner", "step", "--out", "{tmp}/p.json"]),
    ("verify_plan", ["--plan", "{tmp}/p.json"]),
    ("evaluate", ["--suite", "suites/step.json", "--out", "{tmp}/r.json"]),
    ("certify_plans", ["--suite", "suites/step.json", "--out", "{tmp}/r.json"]),
    ("make_suites", ["--out", "{tmp}/suites"]),
    ("generate_dataset", ["--out", "{tmp}/data"]),
    ("train_ranker", ["--out", "{tmp}/r.pt", "--data-dir", "{tmp}/rk"]),
    ("train_hopper", ["--out", "{tmp}/folder"]),
]
BAD_HOPPERS = [("{tmp}/bad-mass.json", "mass must be a positive finite number"),
               ("{tmp}/no-stiffness.toml", "missing the field 'stiffness'"),
               ("{tmp}/missing.json", "no such hopper file or folder")]


@pytest.mark.parametrize("hopper, message", BAD_HOPPERS, ids=[m for _, m in BAD_HOPPERS])
@pytest.mark.parametrize("script, args", HOPPER_PROBES, ids=[s for s, _ in HOPPER_PROBES])
def test_a_bad_hopper_exits_2_in_one_line_naming_the_field(inputs, run_script, script, args, hopper, message):
    # --hopper first: argparse reads the arguments in order, and a bad one is the first error
    code, out, err = run_script(script, "--hopper", hopper.format(tmp=inputs), *(a.format(tmp=inputs) for a in args))
    assert code == 2, (code, err[-600:])
    assert err.count("\n") == 1 and "--hopper" in err and message in err, err
    assert "reproduce with" not in out   # refused before any work


TERRAIN_PROBES = [("plan_and_hop", []), ("make_plan", ["--planner", "step", "--out", "{tmp}/p.json"]),
                  ("verify_plan", ["--plan", "{tmp}/p.json"])]


@pytest.mark.parametrize("script, args", TERRAIN_PROBES, ids=[s for s, _ in TERRAIN_PROBES])
def test_a_bad_terrain_file_exits_2_in_one_line_naming_the_row(inputs, run_script, script, args):
    code, _, err = run_script(script, "--terrain", inputs / "bad-row.csv", *(a.format(tmp=inputs) for a in args))
    assert code == 2 and err.count("\n") == 1, err
    assert "bad-row.csv, line 3: height 'abc' is not a number" in err


def test_a_terrain_folder_with_a_bad_file_exits_2_naming_it(inputs, run_script):
    folder = inputs / "profiles"
    folder.mkdir()
    (folder / "a.csv").write_text(PROFILE)
    (folder / "b.csv").write_text((inputs / "bad-row.csv").read_text())
    code, _, err = run_script("make_suites", "--terrains", folder, "--out", inputs / "suites")
    assert code == 2 and err.count("\n") == 1 and "b.csv, line 3" in err, err


def test_make_suites_draws_for_a_hopper_and_from_a_folder_of_profiles(inputs, run_script):
    from planners.formats.suite import load_suite

    code, _, err = run_script("make_suites", "--hopper", inputs / "big.json", "--families", "ditch", "--seed",
                              "7000", "--terrains", "1", "--out", inputs / "suites")
    assert code == 0, err
    drawn = load_suite(inputs / "suites" / "ditch-7000.json")
    expected = draw_suite("ditch", 7000, load_hopper(inputs / "big.json"), n_terrains=1, name="ditch-7000")
    assert drawn.hopper.params == BIG.params and drawn.to_dict() == expected.to_dict()
    (inputs / "profiles").mkdir()
    (inputs / "profiles" / "ground.csv").write_text(PROFILE)
    code, _, err = run_script("make_suites", "--hopper", inputs / "big.json", "--terrains", inputs / "profiles",
                              "--out", inputs / "suites")
    assert code == 0, err
    suite = load_suite(inputs / "suites" / "profiles.json")
    assert len(suite.cases) == 10 and suite.hopper.name == "big"
    assert suite.cases[0].terrain.is_ditch_at(6.2) and not suite.cases[0].terrain.is_ditch_at(5.9)


def test_the_paper_hoppers_one_case_is_the_demo_it_always_was():
    for family, make in TERRAIN_FAMILIES.items():
        suite = one_case(family, 3)
        case, terrain = suite.cases[0], make(3)
        assert suite.hopper is None and suite.goal_x == 10.0 and suite.friction == 0.8
        assert tuple(case.apex) == (0.0, terrain.height_at(0.0) + 0.9, 2.0)
        assert np.array_equal(case.terrain.heights, terrain.heights)
        assert (case.terrain.cell, case.terrain.x0, case.terrain.ditch_height) == \
            (terrain.cell, terrain.x0, terrain.ditch_height)


def test_another_hoppers_one_case_is_in_its_units_and_checks_the_goal():
    suite = one_case("ditch", 3, BIG)
    assert suite.hopper.name == "big" and suite.cases[0].apex.z > 0.9 and suite.goal_x > 10.0
    with pytest.raises(ValueError, match="goal x=40 must lie ahead of the start x=0 and on the terrain"):
        one_case("ditch", 3, BIG, goal_x=40.0)


def test_on_a_profile_away_from_x0_the_case_starts_on_its_ground_and_ends_before_its_end():
    from drakeslip.terrain_file import terrain_with_gaps

    ground = terrain_with_gaps(np.r_[[np.nan] * 10, np.zeros(110)], 0.1, 5.0)   # solid from x = 6 to 17
    suite = one_case(ground, hopper=BIG)
    assert suite.cases[0].apex.x == pytest.approx(6.7) and suite.goal_x == pytest.approx(17.0 - 0.7)
    assert one_case(ground, hopper=BIG, start_x=8.0, goal_x=12.0).cases[0].apex.x == 8.0
    with pytest.raises(ValueError, match="the start x=5.5 is not on solid ground"):
        one_case(ground, hopper=BIG, start_x=5.5)


@pytest.fixture(scope="module")
def big_plan():
    """A step plan for BIG on the first case of a ditch suite drawn for it, with its params."""
    suite = draw_suite("ditch", 7000, BIG, n_terrains=1, speeds=(2.0,), heights=(0.9,))
    case, params = suite.cases[0], BIG.params.with_friction(suite.friction)
    window = case.terrain.perceived(case.apex.x, *BIG.units.window)
    plan = make_planners({"step": None})["step"].plan(case.apex, window, suite.goal_x, params)
    assert plan.success, plan.message
    return plan, case, suite.goal_x, params


def test_a_plan_file_records_its_hopper_and_reads_back(tmp_path, big_plan):
    plan, case, goal_x, params = big_plan
    save_plan(tmp_path / "plan.json", plan, case.apex, case.terrain, goal_x, params, BIG)
    record = load_plan(tmp_path / "plan.json")
    assert json.loads((tmp_path / "plan.json").read_text())["hopper"]["name"] == "big"
    assert record.hopper.params == BIG.params and record.hopper.name == "big"
    paper = PlanRecord.from_plan(plan, case.apex, case.terrain, goal_x, SlipParams(friction=0.8))
    assert paper.hopper is paper_hopper() and hopper_for(params).name == "custom"


def test_a_plan_whose_hopper_record_is_not_its_params_is_malformed(tmp_path, big_plan):
    plan, case, goal_x, params = big_plan
    save_plan(tmp_path / "plan.json", plan, case.apex, case.terrain, goal_x, params, BIG)
    doc = json.loads((tmp_path / "plan.json").read_text())
    doc["hopper"]["params"]["stiffness"] = 5000.0
    (tmp_path / "plan.json").write_text(json.dumps(doc))
    with pytest.raises(ValueError, match="plan.json: the plan's params is for another hopper .* stiffness 6000.0"):
        load_plan(tmp_path / "plan.json")


def test_a_plan_checked_against_another_hopper_is_refused(tmp_path, big_plan, run_script):
    plan, case, goal_x, params = big_plan
    record = save_plan(tmp_path / "plan.json", plan, case.apex, case.terrain, goal_x, params, BIG)
    with pytest.raises(ValueError, match=r"the plan is for another hopper \(12 kg, L0 0.7 m, 6000 N/m, stroke 0.4\) "
                                         r"than 'paper' \(7 kg, L0 0.5 m, 3200 N/m, stroke 0.4\): mass 12.0 != 7.0"):
        check_plan(record, hopper=paper_hopper())
    code, out, err = run_script("verify_plan", "--plan", tmp_path / "plan.json", "--hopper", "paper")
    assert code == 2 and err.count("\n") == 1 and "is for another hopper" in err and "mass 12.0 != 7.0" in err
    assert out == ""


def test_a_suite_run_with_another_hopper_is_refused_in_one_line(tmp_path, run_script, inputs):
    for script, args in (("evaluate", ["--out", tmp_path / "r.json"]), ("certify_plans", ["--out", tmp_path / "r.json"]),
                         ("make_plan", ["--case", "0", "--planner", "step", "--out", tmp_path / "p.json"])):
        code, _, err = run_script(script, "--suite", "suites/ditch.json", "--hopper", inputs / "big.json", *args)
        assert code == 2 and err.count("\n") == 1, err
        assert "suite 'ditch' is for another hopper" in err and "make_suites.py --hopper" in err
    suite = draw_suite("ditch", 7000, BIG, n_terrains=1)
    assert hopper_for_suite(suite) is suite.hopper
    assert hopper_for_suite(suite, load_hopper(inputs / "big.json")).name == "big"


def test_a_hopper_folder_s_weights_replace_the_committed_ones(tmp_path):
    folder = make_hopper_folder(BIG, tmp_path / "big")
    assert hopper_options("lstm", None, folder) is None   # a folder with no weights changes nothing
    (tmp_path / "big" / EXPERT_WEIGHTS.name).write_bytes(EXPERT_WEIGHTS.read_bytes())
    record_digest(tmp_path / "big" / EXPERT_WEIGHTS.name)
    options = hopper_options("lstm", None, folder)
    assert files_read("lstm", options) == {"model": str(tmp_path / "big" / EXPERT_WEIGHTS.name),
                                           "ranker": str(RANKER_WEIGHTS), "map_model": str(SPATIAL_WEIGHTS)}
    assert files_read("lstm-guided", hopper_options("lstm-guided", None, folder)) == {
        "model": str(SUBCELL_WEIGHTS), "map_model": str(SPATIAL_WEIGHTS)}
    trajopt = hopper_options("trajopt", {"seed": "lstm-guided@expert"}, folder)
    assert trajopt["seed_options"] == {"model": str(tmp_path / "big" / EXPERT_WEIGHTS.name)}
    assert hopper_options("lstm", {"ranker": None}, paper_hopper()) == {"ranker": None}
    make_planners({"lstm": options})   # the folder's file matches its manifest
    changed = make_hopper_folder(BIG, tmp_path / "changed")
    (tmp_path / "changed" / EXPERT_WEIGHTS.name).write_bytes(EXPERT_WEIGHTS.read_bytes())
    record_digest(tmp_path / "changed" / EXPERT_WEIGHTS.name)
    (tmp_path / "changed" / EXPERT_WEIGHTS.name).write_bytes(EXPERT_WEIGHTS.read_bytes() + b"\0")
    with pytest.raises(ValueError, match="lstm_expert.pt does not match its SHA-256"):
        make_planners({"lstm": hopper_options("lstm", None, changed)})


@pytest.mark.slow
def test_a_profile_goes_through_plan_and_hop_make_plan_verify_plan_and_the_replay(inputs, run_script):
    """The 12 kg hopper on a terrain file: plan_and_hop reaches the goal on Drake and writes the replay; the plan
    made on the file is certified on it by verify_plan, which writes its own replay."""
    code, out, err = run_script("plan_and_hop", "--hopper", inputs / "big.json", "--terrain", inputs / "ground.csv",
                                "--out", inputs / "run.png", "--html", inputs / "replay.html")
    assert code == 0, (out[-800:], err[-800:])
    assert "for hopper big" in out and "reached the goal" in out
    assert (inputs / "replay.html").stat().st_size > 10_000 and (inputs / "run.png").is_file()
    code, out, err = run_script("make_plan", "--hopper", inputs / "big.json", "--terrain", inputs / "ground.csv",
                                "--planner", "step", "--out", inputs / "plan.json")
    assert code == 0, err
    record = load_plan(inputs / "plan.json")
    assert record.hopper.name == "big" and record.terrain.is_ditch_at(6.2)
    code, out, err = run_script("verify_plan", "--plan", inputs / "plan.json", "--hopper", inputs / "big.json",
                                "--terrain", inputs / "ground.csv", "--out", inputs / "check.json",
                                "--html", inputs / "check.html")
    assert code == 0 and "CERTIFIED" in out, (out[-800:], err)
    assert json.loads((inputs / "check.json").read_text())["hopper"]["name"] == "big"
    assert (inputs / "check.html").stat().st_size > 10_000


@pytest.mark.slow
def test_train_hopper_at_a_tiny_size_writes_a_folder_the_planners_use(inputs, run_script, monkeypatch):
    monkeypatch.setenv("PYTHONPATH", str(ROOT))   # the steps run as scripts of this checkout
    folder = inputs / "big-folder"
    args = ["--hopper", inputs / "big.json", "--out", folder, "--terrains", "2", "--apexes", "2", "--epochs", "1",
            "--ranker-rounds", "1", "--ranker-terrains", "1", "--ranker-epochs", "2", "--device", "cpu", "--quiet"]
    code, out, err = run_script("train_hopper", *args)
    assert code == 0, (out[-1500:], err[-1500:])
    hopper = load_hopper(folder)
    assert hopper.name == "big" and hopper.params == BIG.params and hopper.folder == folder
    manifest = (folder / MANIFEST).read_text()
    assert all(f"  {name}\n" in manifest for name in ("hopper.json", EXPERT_WEIGHTS.name, RANKER_WEIGHTS.name))
    assert hopper.weights(EXPERT_WEIGHTS.name) is not None and hopper.weights(RANKER_WEIGHTS.name) is not None
    code, out, _ = run_script("train_hopper", *args)   # every step done: nothing runs again
    assert code == 0 and out.count(": done") == 3
    suite = draw_suite("ditch", 7000, BIG, n_terrains=1, speeds=(2.0,), heights=(0.9,))
    (inputs / "suite.json").write_text(json.dumps(suite.to_dict()))
    code, out, err = run_script("make_plan", "--suite", inputs / "suite.json", "--case", "0", "--planner", "lstm",
                                "--hopper", folder, "--out", inputs / "plan.json")
    assert code in (0, 1), err   # the one-step planner may find no plan; it ran with the folder's weights
    assert files_read("lstm", hopper_options("lstm", None, hopper)) == {
        "model": str(folder / EXPERT_WEIGHTS.name), "ranker": str(folder / RANKER_WEIGHTS.name),
        "map_model": str(SPATIAL_WEIGHTS)}   # a hopper folder holds no height-map model: the committed one


def test_hop_runs_another_hopper_on_a_terrain_file(inputs, run_script):
    code, out, err = run_script("hop", "--hopper", inputs / "big.json", "--terrain", inputs / "ground.csv",
                                "--hops", "3", "--out", inputs / "hop.png")
    assert code == 0, err
    assert "file " in out and "outcome: ok, 3 hops" in out and (inputs / "hop.png").is_file()


def test_the_controller_lands_a_soft_small_hoppers_targets(tmp_path, run_script):
    """The controller trained on the paper's hopper, for the 3 kg, 0.3 m hopper of dimensionless stiffness 10 and
    friction 0.6 (the corner of the range farthest from the paper's): after its polish every target is hit."""
    params = SlipParams(mass=3.0, leg_length=0.3, stiffness=10.0 * 3.0 * 9.81 / 0.3, friction=0.6)
    hopper = NamedHopper(params, "corner")
    save_hopper(hopper, tmp_path / "corner.json")
    code, out, err = run_script("controller_accuracy", "--hopper", tmp_path / "corner.json", "--samples", "500",
                                "--drake", "0")
    assert code == 0, err
    refined = [line for line in out.splitlines() if "refined" in line]
    assert len(refined) == 2 and all("misses 0/" in line and "misses 0/0" not in line for line in refined), out
