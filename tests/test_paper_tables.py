"""examples/paper_tables.py: its tables set the paper's numbers (verification/paper.py) beside ours, "-" for a
planner the paper did not run, and it refuses a run whose results would overwrite each other before any work."""
from pathlib import Path

from verification.paper import TABLES, reported

ROOT = Path(__file__).resolve().parents[1]


def results(*labels) -> dict:
    """A results dict of examples/evaluate.py with the fields the tables read, one case per label."""
    block = {"success_rate": 0.5, "success_interval": [0.1, 0.9], "ode_calls_mean": 100.0, "t_plan_mean_s": 0.01,
             "t_plan_median_s": 0.01, "nodes_expanded_mean": 5.0, "footholds_mean": 4.0, "cases": [{}]}
    return {"suite": "ditch", "planners": {label: block for label in labels}}


def test_the_paper_reports_its_five_planners_on_its_two_suites():
    assert set(TABLES) == {"ditch", "step"}
    assert reported("ditch", "step") == (86.6, 30857, 0.29) and reported("step", "lstm-guided") == (96, 6932, 0.04)
    assert reported("ditch", "trajopt") is None and reported(None, "step") is None


def test_a_planner_the_paper_did_not_run_gets_a_dash(example):
    markdown = example("paper_tables").markdown
    rows = {line.split(" | ")[0]: line for line in markdown(results("step", "trajopt", "lstm@paper"), "ditch")
            .splitlines() if line.startswith("| ") and "Planner" not in line}
    assert rows["| Step-space"].endswith(" 86.6 / 30857 / 0.29 s | 0.58x / 0.00x / 0.03x |")
    assert rows["| LSTM (@paper: the paper's model and settings)"].endswith(" 56 / 0 / 0.007 s | 0.89x / - / 1.43x |")
    assert rows["| trajopt"].endswith(" - | - |")
    assert all(row.count("|") == 11 for row in rows.values())   # every row has the paper's two columns
    assert "paper" not in markdown(results("step", "trajopt"), None)   # another suite: no paper columns


def test_suites_of_one_name_are_refused_before_any_work(run_script, tmp_path):
    step = ROOT / "suites" / "step.json"
    code, out, err = run_script("paper_tables", "--ditch", step, "--step", step, "--planners", "heuristic",
                                "--out", tmp_path / "tables")
    assert code == 2 and "two suites are named 'step'" in err and len(err.splitlines()) == 1
    assert "reproduce with" not in out and not any((tmp_path / "tables").glob("*.json"))
