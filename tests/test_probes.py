"""Bad input to the scripts users run: every probe exits 2 with one line naming the bad value, before any planning
or simulation starts. ``python3 tests/test_probes.py`` prints the probes as the markdown table in
docs/verification.md (probe, expected, observed)."""
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SUITE = "suites/step.json"

# (script, arguments, text the one line of stderr must contain); {dir} is a folder made for the probe, {bad} a
# file of 100 bytes that is not a weights file, {missing} a path that does not exist
PROBES = [
    ("evaluate", ["--suite", SUITE, "--out", "{dir}"], "--out: '{dir}' is a folder"),
    ("evaluate", ["--suite", SUITE, "--out", "{dir}/../r.json", "--controller", "{missing}"], "--controller:"),
    ("evaluate", ["--suite", SUITE, "--out", "{dir}/../r.json", "--controller", "{bad}"], "bad.pt"),
    ("evaluate", ["--suite", SUITE, "--out", "{dir}/../r.json", "--planners", "lstm",
                  "--options", '{{"lstm": {{"model": "{bad}"}}}}'], "bad.pt"),
    ("evaluate", ["--suite", SUITE, "--out", "{dir}/../r.json", "--executed", "0"], "--executed: must be an integer in [1, inf], got"),
    ("evaluate", ["--suite", SUITE, "--out", "{dir}/../r.json", "--executed", "-1"], "--executed: must be an integer in [1, inf], got"),
    ("evaluate", ["--suite", SUITE, "--out", "{dir}/../r.json", "--planners", ","], "--planners: must name at least one"),
    ("evaluate", ["--suite", SUITE, "--out", "{dir}/../r.json", "--map-filter", "4"], "--map-filter: map_filter must be odd"),
    ("evaluate", ["--suite", SUITE, "--out", "{dir}/../r.json", "--noise", "loud"], "unknown noise profile 'loud'"),
    ("plan_and_hop", ["--friction", "-1"], "--friction: must be a finite number > 0.0, got '-1'"),
    ("plan_and_hop", ["--speed", "nan"], "--speed: must be a finite number > 0.0, got 'nan'"),
    ("plan_and_hop", ["--out", "x.xyz"], "--out: must end in .png or .pdf or .svg, got 'x.xyz'"),
    ("plan_and_hop", ["--html", "replay.htm"], "--html: must end in .html, got 'replay.htm'"),
    ("plan_and_hop", ["--noise", "realistic*2x"], "--noise: noise scale in 'realistic*2x' must be a number"),
    ("verify_plan", ["--plan", "{missing}"], "--plan:"),
    ("verify_plan", ["--plan", "{bad}"], "bad.pt"),
    ("robustness", ["--plan", "{bad}"], "bad.pt"),
    ("robustness", ["--plan", "{bad}", "--noise", "realistic*-1"], "--noise"),
    ("robustness", ["--plan", "{bad}", "--map-filter", "2"], "--map-filter must be odd"),
    ("model_check", ["--suite", SUITE, "--out", "{dir}"], "--out: '{dir}' is a folder"),
    ("make_plan", ["--suite", SUITE, "--planner", "step", "--case", "999", "--out", "{dir}/../p.json"], "--case"),
]


def run_probe(script: str, args: list, folder: Path) -> subprocess.CompletedProcess:
    (folder / "bad.pt").write_bytes(b"\x80not a weights file" + bytes(82))
    (folder / "out.json").mkdir(exist_ok=True)   # a folder where a results file would go
    fill = {"dir": str(folder / "out.json"), "bad": str(folder / "bad.pt"), "missing": str(folder / "missing.pt")}
    argv = [a.format(**fill) for a in args]
    return subprocess.run([sys.executable, str(ROOT / "examples" / f"{script}.py"), *argv], capture_output=True,
                          text=True, cwd=ROOT, timeout=120)


def expected(message: str, folder: Path) -> str:
    return message.format(dir=str(folder / "out.json"))


@pytest.mark.parametrize("script, args, message", PROBES, ids=[f"{s} {' '.join(a[-2:])}" for s, a, _ in PROBES])
def test_a_bad_argument_exits_2_in_one_line_before_any_work(tmp_path, run_script, script, args, message):
    (tmp_path / "bad.pt").write_bytes(b"\x80not a weights file" + bytes(82))
    (tmp_path / "out.json").mkdir()
    fill = {"dir": str(tmp_path / "out.json"), "bad": str(tmp_path / "bad.pt"), "missing": str(tmp_path / "missing.pt")}
    code, out, err = run_script(script, *(a.format(**fill) for a in args))   # in this process: no start-up cost
    assert code == 2, (code, err[-800:])
    assert len(err.splitlines()) == 1 and expected(message, tmp_path) in err, err
    assert "reproduce with" not in out + err   # refused before the run was announced


def markdown() -> str:
    import tempfile

    rows = ["| probe | expected | observed (exit status: stderr) |", "|---|---|---|"]
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        for script, args, message in PROBES:
            run = run_probe(script, args, folder)
            shown = " ".join(args).replace(SUITE, "S").format(dir="TMP/out.json", bad="TMP/bad.pt",
                                                              missing="TMP/missing.pt")
            shown = shown.replace("TMP/out.json/../", "TMP/")
            line = run.stderr.strip().replace(str(folder), "TMP").replace("|", "\\|")
            rows.append(f"| `{script}.py {shown}` | 2, one line | {run.returncode}: `{line}` |")
    return "\n".join(rows)


if __name__ == "__main__":
    print(markdown())
