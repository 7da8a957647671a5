"""Adversarial plan files: a certificate means the plan as written, so every tampered plan gets its own verdict: a
counterexample of a given kind at a given hop, the first mismatch (exit 1), or a malformed file (exit 2, one line
naming the field)."""
import json

import pytest

import drakeslip as ds
import planners
from planners.formats.plan import PlanRecord
from planners.formats.suite import make_suite
from verification.plan_check import Certificate, Counterexample, check_plan


@pytest.fixture(scope="module")
def plan_doc():
    """Step-space's plan for case 7 of the committed step suite (4 hops, leg angles and apexes predicted)."""
    suite = make_suite("step", seed=2000, n_terrains=1)
    case = suite.cases[7]
    params = ds.SlipParams(friction=suite.friction)
    plan = planners.make("step").plan(case.apex, case.terrain.perceived(case.apex.x), suite.goal_x, params)
    doc = PlanRecord.from_plan(plan, case.apex, case.terrain, suite.goal_x, params).to_dict()
    assert len(doc["footholds"]) == 4
    return doc


def tampered(doc, edit):
    doc = json.loads(json.dumps(doc))
    edit(doc)
    return doc


def verdict(tmp_path, run_script, doc, *args):
    (tmp_path / "plan.json").write_text(json.dumps(doc))
    return run_script("verify_plan", "--plan", tmp_path / "plan.json", *args)


def test_the_untampered_plan_is_certified(tmp_path, run_script, plan_doc):
    code, out, err = verdict(tmp_path, run_script, plan_doc)
    assert code == 0, out + err
    assert "CERTIFIED: all 4 hops of the plan" in out and "within 0.01" in out


def move(i, dx, key="footholds"):
    def edit(doc):
        doc[key][i] = doc[key][i] + dx if key == "footholds" else [doc[key][i][0], doc[key][i][1] + dx, doc[key][i][2]]
    return edit


def cut(n):
    def edit(doc):
        for key in ("footholds", "leg_angles", "apexes"):
            doc[key] = doc[key][:n]
    return edit


# tampering -> (edit, the counterexample's kind and hop, its reason), as in docs/verification.md's table
COUNTEREXAMPLES = {
    "one foothold moved 5 cm": (move(2, 0.05), ("foothold", 2), "FOOTHOLD MISSED at hop 2"),
    "the last foothold moved 2 cm": (move(3, -0.02), ("foothold", 3), "FOOTHOLD MISSED at hop 3"),
    "a predicted apex 3 cm higher": (move(1, 0.03, "apexes"), ("apex", 1), "APEX MISSED after hop 1"),
    "a predicted apex's speed changed": (lambda d: d["apexes"][0].__setitem__(2, d["apexes"][0][2] + 0.05),
                                         ("apex", 0), "APEX MISSED after hop 0"),
    "cut to 1 of 4 hops": (cut(1), ("target", 0), "SHORT OF TARGET after its 1 hops: the plan claims target "
                                                  "x=5.9625, its last touchdown is at x=-0.0125"),
    "cut to 3 of 4 hops": (cut(3), ("target", 2), "SHORT OF TARGET after its 3 hops"),
    "a target beyond its footholds": (lambda d: d.update(target_x=9.0), ("target", 3),
                                      "SHORT OF TARGET after its 4 hops"),
    "a leg angle changed": (lambda d: d["leg_angles"].__setitem__(1, d["leg_angles"][1] + 0.02), ("foothold", 1),
                            "FOOTHOLD MISSED at hop 1"),
}


FAST = ("one foothold moved 5 cm", "cut to 1 of 4 hops")  # the rest run with -m slow (each is a Drake run)


@pytest.mark.parametrize("name", [n if n in FAST else pytest.param(n, marks=pytest.mark.slow) for n in COUNTEREXAMPLES])
def test_a_tampered_plan_gets_a_counterexample_naming_the_first_mismatch(tmp_path, run_script, plan_doc, name):
    edit, (kind, hop), reason = COUNTEREXAMPLES[name]
    (tmp_path / "check.json").unlink(missing_ok=True)
    code, out, _ = verdict(tmp_path, run_script, tampered(plan_doc, edit), "--out", tmp_path / "check.json")
    assert code == 1 and "CERTIFIED" not in out
    assert f"COUNTEREXAMPLE: {reason}" in out, out
    check = json.loads((tmp_path / "check.json").read_text())
    assert check["verdict"] == "counterexample" and (check["kind"], check["hop"]) == (kind, hop), check["reason"]
    assert reason in check["reason"]
    assert set(check["hybrid"]) >= {"mode", "leg_angle", "foot_x", "foot_z", "hops"} and len(check["state"]) == 4


MALFORMED = {
    "footholds reversed": (lambda d: d.update(footholds=d["footholds"][::-1]), r"behind footholds\[0\].*two leg reaches"),
    "a foothold 4 m back, 2.1 m behind the one before": (move(2, -4.0), r"footholds\[2\] = .* m behind footholds\[1\]"),
    "predicted apexes going back": (lambda d: d["apexes"][2].__setitem__(0, d["apexes"][1][0] - 0.1),
                                    r"apexes\[2\] x = .* is not past apexes\[1\]"),
    "fewer leg angles than footholds": (lambda d: d["leg_angles"].pop(), "a list of 4 entries"),
    "an apex row cut short": (lambda d: d["apexes"][1].pop(), r"apexes\[1\] must be \[x, z, xdot\]"),
    "a start apex below the terrain": (lambda d: d["apex"].update(z=-0.5), "not above the terrain"),
    "a predicted apex below the terrain": (lambda d: d["apexes"][2].__setitem__(1, -0.9), "not above the terrain"),
    "an apex given in part": (lambda d: d["apexes"][0].__setitem__(2, None), "given in part"),
    "a leg angle of 2 rad": (lambda d: d["leg_angles"].__setitem__(0, 2.0), r"leg_angles\[0\] = 2 is outside"),
    "a NaN-looking foothold": (lambda d: d["footholds"].__setitem__(0, "nan"), r"footholds\[0\] must be"),
    "a boolean friction": (lambda d: d["params"].update(friction=True), "friction must be a positive"),
    "an unknown format": (lambda d: d.update(format="drakeslip-plan/9"), "format must be one of"),
    "a ditch height that is not a number": (lambda d: d["terrain"].update(ditch_height=None), "ditch_height"),
}


@pytest.mark.parametrize("name", list(MALFORMED))
def test_a_plan_whose_fields_disagree_is_malformed(tmp_path, run_script, plan_doc, name):
    edit, message = MALFORMED[name]
    code, out, err = verdict(tmp_path, run_script, tampered(plan_doc, edit))
    assert code == 2 and not out and len(err.splitlines()) == 1, (out, err)
    assert __import__("re").search(message, err), err


def test_a_slow_gait_may_step_back_a_little(plan_doc):
    """A slow hopper can put its foot behind the last foothold (the body still moves forward): the format takes it."""
    doc = tampered(plan_doc, lambda d: d["footholds"].__setitem__(2, d["footholds"][1] - 0.05))
    assert PlanRecord.from_dict(doc).footholds[2] == pytest.approx(plan_doc["footholds"][1] - 0.05)


def test_a_start_inside_a_ditch_is_malformed(plan_doc):
    doc = tampered(plan_doc, lambda d: None)
    heights = doc["terrain"]["heights"]
    i = int(round((doc["apex"]["x"] - doc["terrain"]["x0"]) / doc["terrain"]["cell"]))
    heights[i - 2:i + 3] = [-1.0] * 5
    doc["apex"]["z"] = -0.4
    with pytest.raises(ValueError, match="inside a ditch"):
        PlanRecord.from_dict(doc)


@pytest.mark.slow
def test_a_plan_without_angles_is_checked_on_its_footholds_and_apexes(plan_doc):
    """Footholds mode (no angles): the controller aims at the footholds as written, so a moved foothold is
    followed, and the predicted apexes are what catch it; without them, the hop after it is: from where the moved
    foothold leaves the hopper, the controller lands 5 cm short of the next one."""
    doc = tampered(plan_doc, lambda d: d.update(leg_angles=[None] * 4))
    assert isinstance(check_plan(PlanRecord.from_dict(doc)), Certificate)
    moved = check_plan(PlanRecord.from_dict(tampered(doc, move(1, 0.02))))
    assert isinstance(moved, Counterexample) and moved.kind == "apex" and moved.hop == 1, moved.format()
    no_apexes = tampered(doc, lambda d: d.update(apexes=[[None] * 3] * 4))
    followed = check_plan(PlanRecord.from_dict(tampered(no_apexes, move(1, 0.02))))
    assert isinstance(followed, Counterexample) and (followed.kind, followed.hop) == ("foothold", 2), followed.format()
    assert followed.trace[1]["foothold"] == pytest.approx(followed.trace[1]["planned_foothold"], abs=0.01)


@pytest.mark.slow
def test_the_tolerance_is_the_users_and_checked(tmp_path, run_script, plan_doc):
    doc = tampered(plan_doc, move(2, 0.005))
    assert verdict(tmp_path, run_script, doc)[0] == 0            # 5 mm: inside the 1 cm default
    assert verdict(tmp_path, run_script, doc, "--tolerance", "0.002")[0] == 1
    for bad in ("0", "-1", "nan", "inf"):
        code, _, err = verdict(tmp_path, run_script, doc, "--tolerance", bad)
        assert code == 2 and "--tolerance" in err
    with pytest.raises(ValueError, match="tolerance must be a positive"):
        check_plan(PlanRecord.from_dict(doc), tolerance=0.0)
    # the planner aimed at x = 6; its footholds end at the edge of its view, so its plan claims its last one
    assert PlanRecord.from_dict(plan_doc).target_x == plan_doc["footholds"][-1] == 5.9625
