"""examples/certify_plans.py's case cache: a record is reused only for the code, planner options and weights files
that made it, and a damaged one is named and checked again."""
import json

import pytest

from verification import certify, provenance

ARGS = ["--suite", "suites/ditch.json", "--planners", "heuristic", "--every", "50", "--cases", "1", "--quiet"]


def test_a_certificate_is_reused_only_for_the_code_that_made_it(tmp_path, monkeypatch, run_script):
    out = tmp_path / "c.json"
    monkeypatch.setattr(provenance, "code_version", lambda: "git:one")
    code, stdout, _ = run_script("certify_plans", *ARGS, "--out", out)
    assert code == 0 and "results reused" not in stdout
    first = json.loads(out.read_text())
    assert first["provenance"]["code_version"] == "git:one"
    code, stdout, _ = run_script("certify_plans", *ARGS, "--out", out)
    assert code == 0 and "1 of 1 results reused" in stdout
    assert json.loads(out.read_text())["plans"] == first["plans"]
    monkeypatch.setattr(provenance, "code_version", lambda: "git:two")
    code, stdout, _ = run_script("certify_plans", *ARGS, "--out", out)
    assert code == 0 and "0 of 1 results reused; 1 made by other code ignored" in stdout


def test_a_damaged_cached_certificate_is_skipped_with_a_warning(tmp_path, monkeypatch, run_script):
    out = tmp_path / "c.json"
    monkeypatch.setattr(provenance, "code_version", lambda: "git:one")
    assert run_script("certify_plans", *ARGS, "--out", out)[0] == 0
    cache = tmp_path / "c.json.cases.jsonl"
    line = json.loads(cache.read_text())
    line["result"]["verdict"] = "fine"
    cache.write_text(json.dumps(line) + "\n")
    code, _, err = run_script("certify_plans", *ARGS, "--out", out)
    assert code == 0 and "1 damaged line skipped" in err and "verdict must be one of" in err
    assert json.loads(out.read_text())["plans"][0]["verdict"] in certify.VERDICTS


@pytest.mark.parametrize("change, message", [
    ({"verdict": "fine"}, "verdict must be one of"), ({"hops": -1}, "hops must be a count"),
    ({"reason": None}, "reason must be a string"), ({"hop": "2"}, "hop must be null or a count"),
])
def test_a_cached_certificate_of_the_wrong_shape_is_named(change, message):
    record = {"label": "step", "id": "c", "verdict": "certified", "reason": "", "hops": 4, "kind": None, "hop": None}
    certify.check_record(record)
    with pytest.raises(ValueError, match=message):
        certify.check_record({**record, **change})
