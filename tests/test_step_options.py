"""Step-space's options are checked when the planner is built: a bad value is a ValueError of one line naming the
option and the value, before any work (the controller's load, the compiled core's warm-up), so a typo in --options
fails at once (exit status 2) instead of running every case to "no plan"; every default and documented value still
builds the planner it always did."""
import math
from pathlib import Path

import pytest

import planners
from drakeslip.params import shown
from planners.search import step_space
from planners.search.step_space import SPACINGS
from planners.search.tree import CostWeights

ROOT = Path(__file__).resolve().parents[1]
NAN, INF = math.nan, math.inf

BAD = [  # (option, value, the value as the message shows it)
    ("tolerance", NAN, "nan"), ("tolerance", -1, "-1"), ("tolerance", 0.0, "0.0"), ("tolerance", INF, "inf"),
    ("tolerance", "0.02", "'0.02'"), ("tolerance", True, "True"), ("tolerance", 1e9, "1000000000.0"),
    ("min_speed", NAN, "nan"), ("min_speed", -0.1, "-0.1"), ("min_speed", "1", "'1'"),
    ("min_speed", 1e9, "1000000000.0"),
    ("edge_margin", NAN, "nan"), ("edge_margin", -0.01, "-0.01"), ("edge_margin", INF, "inf"),
    ("edge_margin", False, "False"),
    ("spacing", "nan", "'nan'"), ("spacing", NAN, "nan"), ("spacing", 1e-9, "1e-09"), ("spacing", -1, "-1"),
    ("spacing", 1e9, "1000000000.0"), ("spacing", 0.0, "0.0"), ("spacing", True, "True"),
    ("spacing", 10**400, "(401 characters)"),
    ("fallback_spacing", (0.01, NAN), "nan"), ("fallback_spacing", [1e-9], "1e-09"), ("fallback_spacing", 0.01, "0.01"),
    ("fallback_spacing", "ab", "'ab'"),
    ("n_sequences", True, "True"), ("n_sequences", 0, "0"), ("n_sequences", 1.5, "1.5"),
    ("cost_weights", (1, 1), "(1, 1)"), ("cost_weights", (1, 1, 2, 3), "(1, 1, 2, 3)"),
    ("cost_weights", "abc", "'abc'"),
    ("cost_weights", (NAN, 1, 2), "nan"), ("cost_weights", [1, -1, 2], "-1"), ("cost_weights", (1, 1, "2"), "'2'"),
    ("cost_weights", CostWeights(1, INF, 2), "inf"),
    ("pruned_nodes", -1, "-1"), ("pruned_nodes", True, "True"), ("pruned_nodes", 1.5, "1.5"),
    ("last_resort_margin", 1, "1"), ("last_resort_margin", NAN, "nan"), ("last_resort_margin", "a", "'a'"),
    ("last_resort_margin", -0.1, "-0.1"),
    ("robustness", {"bogus": 1}, "bogus"), ("robustness", 3, "3"),
    ("fallback_nominal", "false", "'false'"), ("safe_hops", 1, "1"),
    ("step_map", "gpu", "'gpu'"), ("step_map", ["fast"], "['fast']"),
    ("controller", "x", "'x'"),
]


@pytest.mark.parametrize("option, value, value_shown", BAD, ids=[f"{o}={v!r}"[:40] for o, v, _ in BAD])
def test_a_bad_option_is_refused_in_one_line_naming_it_and_its_value(option, value, value_shown):
    with pytest.raises(ValueError) as refused:
        planners.make("step", **{option: value})
    message = str(refused.value)
    assert option in message and value_shown in message and "\n" not in message


def test_the_refusal_comes_before_any_work(monkeypatch):
    """Neither the controller is read nor the compiled core warmed up for a planner that is refused."""
    def work(*args):
        raise AssertionError("work started before the options were checked")
    monkeypatch.setattr(step_space, "warm_up_core", work)
    monkeypatch.setattr(step_space.StepLengthController, "load_default", work)
    for option, value, _ in BAD:
        if option != "controller":
            with pytest.raises(ValueError):
                planners.make("step", **{option: value})


GOOD = [  # the defaults (None: the paper's value in the hopper's units), the documented values and the bounds' ends
    {}, {"spacing": None, "fallback_spacing": None, "tolerance": None, "min_speed": None, "edge_margin": None},
    {"spacing": 0.025, "edge_margin": 0.02}, {"spacing": 0.025, "fallback_spacing": ()}, {"fallback_spacing": [0.01]},
    {"spacing": 0.1 / 4}, {"spacing": SPACINGS.low}, {"spacing": SPACINGS.high}, {"spacing": 1},
    {"min_speed": 0.0}, {"edge_margin": 0.3}, {"edge_margin": 0}, {"tolerance": 0.02, "min_speed": 0.3},
    {"cost_weights": (1, 0, 2)}, {"cost_weights": [1.0, 1.0, 2.0]}, {"cost_weights": CostWeights()},
    {"n_sequences": 3}, {"pruned_nodes": 0}, {"last_resort_margin": None}, {"last_resort_margin": 0},
    {"robustness": {}}, {"robustness": {"sigmas": 3.0, "depth": 3, "max_nodes": 5, "relaxed": ()}},
    {"safe_hops": True, "fallback_nominal": False}, {"step_map": "drake"},
]


@pytest.mark.parametrize("options", GOOD, ids=[str(o)[:40] for o in GOOD])
def test_defaults_and_documented_values_build_the_planner_they_always_did(options):
    planner = planners.make("step", **options)
    for option in ("spacing", "tolerance", "min_speed", "edge_margin", "n_sequences", "pruned_nodes",
                   "last_resort_margin", "safe_hops", "fallback_nominal", "step_map"):
        if option in options:
            assert getattr(planner, option) == options[option], option
    if "fallback_spacing" in options:
        given = options["fallback_spacing"]
        assert planner.fallback_spacing == (None if given is None else tuple(given))
    if "cost_weights" in options:
        given = options["cost_weights"]
        assert planner.cost_weights == (given if isinstance(given, CostWeights) else CostWeights(*given))


def test_the_robust_preset_builds():
    assert planners.make("step@robust").robustness is not None


@pytest.mark.parametrize("options, named", [('{"step": {"tolerance": NaN}}', "tolerance"),
                                            ('{"step": {"spacing": "nan"}}', "spacing"),
                                            ('{"step": {"cost_weights": [1, 1]}}', "cost_weights")])
def test_a_bad_option_on_the_cli_exits_2_in_one_line(tmp_path, run_script, options, named):
    code, _, err = run_script("evaluate", "--suite", ROOT / "suites/step.json", "--planners", "step", "--options",
                              options, "--out", tmp_path / "o.json")
    assert code == 2 and f"--options for step: {named}" in err and len(err.splitlines()) == 1, err
    assert not (tmp_path / "o.json").exists()


def test_messages_show_long_values_short():
    with pytest.raises(ValueError, match=r"spacing must be a positive distance") as refused:
        planners.make("step", spacing="x" * 1000)
    assert shown("x" * 1000) in str(refused.value) and len(str(refused.value)) < 200


@pytest.mark.parametrize("label, option, value, value_shown", [
    ("angle", "min_speed", NAN, "nan"), ("angle", "edge_margin", -1.0, "-1.0"), ("angle", "cost_weights", (1, NAN, 2),
                                                                                 "nan"),
    ("angle", "n_sequences", True, "True"), ("angle", "branching", 0, "0"), ("angle", "seed", -1, "-1"),
    ("lstm", "edge_margin", NAN, "nan")])
def test_the_other_searches_check_the_shared_options_the_same_way(label, option, value, value_shown):
    """Angle-space and the LSTM planner take some of Step-space's options: each is refused as Step-space refuses it."""
    with pytest.raises(ValueError) as error:
        planners.make(label, **{option: value})
    message = str(error.value)
    assert value_shown in message and "\n" not in message, message
