"""Jobs fail safely: killing a parallel job leaves no worker behind and the same command resumes it; a damaged
cache line is skipped with a warning and its result computed again; results of other code are not reused."""
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def descendants(pid: int) -> set[int]:
    """Every live process below ``pid`` (from /proc; zombies, which are already dead, are left out)."""
    children: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            fields = stat.rsplit(")", 1)[1].split()
            if fields[0] != "Z":
                children.setdefault(int(fields[1]), []).append(int(entry.name))
    found, todo = set(), [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            found.add(child)
            todo.append(child)
    return found


def alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def evaluation_command(out: Path, jobs: int) -> list[str]:
    """A small evaluation (16 tasks, executed on Drake: up to a few seconds each, so a job is still running when
    a test stops it) writing ``out``."""
    return [str(ROOT / "examples" / "evaluate.py"), "--suite", str(ROOT / "suites" / "step.json"), "--planners",
            "heuristic,step", "--cases", "8", "--backend", "drake", "--jobs", str(jobs), "--quiet", "--out", str(out)]


def wait_for_saved_results(cache: Path, job: subprocess.Popen, count: int = 1, timeout: float = 180.0) -> None:
    """Until ``cache`` holds ``count`` complete lines (or the job ends, or the time is up)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and job.poll() is None:
        if cache.exists() and cache.read_bytes().count(b"\n") >= count:
            return
        time.sleep(0.1)
    raise AssertionError(f"the job saved fewer than {count} results in {timeout:g} s (exit {job.poll()})")


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc").is_dir(), reason="reads the process table from /proc (Linux)")
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM, signal.SIGINT], ids=lambda s: s.name)
def test_a_killed_two_process_evaluation_leaves_no_worker_and_resumes(tmp_path, run_script, sig):
    out = tmp_path / "results.json"
    cache = Path(str(out) + ".cases.jsonl")
    job = subprocess.Popen([sys.executable, *evaluation_command(out, 2)], stdout=subprocess.DEVNULL,
                           stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        wait_for_saved_results(cache, job)
        workers = {p for p in descendants(job.pid) if "spawn_main" in Path(f"/proc/{p}/cmdline").read_bytes()
                   .decode(errors="replace")}
        assert len(workers) == 2, "the job does not run its two workers"
        everyone = descendants(job.pid)
        os.kill(job.pid, sig)
        job.wait(timeout=60)
    finally:
        if job.poll() is None:
            job.kill()
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and any(alive(p) for p in everyone):
        time.sleep(0.2)
    left = [p for p in everyone if alive(p)]
    for p in left:  # do not leave them to the next test
        os.kill(p, signal.SIGKILL)
    assert not left, f"processes left after {sig.name} of the parent: {left}"
    assert job.returncode != 0 and not out.exists()
    # the results saved before the kill are reused by the same command, and only the others run
    saved = sum(1 for line in cache.read_bytes().splitlines() if line.endswith(b"}}"))
    assert 1 <= saved < 16
    code, stdout, _ = run_script("evaluate", *evaluation_command(out, 1)[1:])
    assert code == 0 and f"{saved} of 16 results reused" in stdout, stdout
    results = json.loads(out.read_text())
    assert [len(block["cases"]) for block in results["planners"].values()] == [8, 8]
    assert sum(1 for line in cache.read_bytes().splitlines() if line.endswith(b"}}")) == 16


def test_a_cache_with_undecodable_bytes_resumes(tmp_path):
    from drakeslip.jobs.runner import JsonLinesStore

    path = tmp_path / "cache.jsonl"
    store = JsonLinesStore(path)
    store.put("a", {"value": 1})
    store.close()
    with open(path, "ab") as f:
        f.write(b"\xff\xfe not utf-8 \x80\n")
    store = JsonLinesStore(path)
    assert store.skipped == [(2, "not UTF-8 JSON")]
    store.put("b", {"value": 2})
    store.close()
    again = JsonLinesStore(path)
    assert again.get("a") == {"value": 1} and again.get("b") == {"value": 2}


def test_a_cached_result_lacking_a_field_is_computed_again_with_a_warning(tmp_path, capsys):
    from drakeslip.jobs.runner import JsonLinesStore, has_fields, run

    path = tmp_path / "cache.jsonl"
    path.write_text('{"key": "a", "result": {"success": true, "x": 1}}\n{"key": "b", "result": {"x": 2}}\n')
    calls = []

    def compute(x):
        calls.append(x)
        return {"success": True, "x": x}

    results = dict(run(compute, [("a", (1,)), ("b", (2,))], JsonLinesStore(path, has_fields("success"))))
    assert calls == [2] and results == {"a": {"success": True, "x": 1}, "b": {"success": True, "x": 2}}
    out, err = capsys.readouterr()
    assert "1 of 2 results reused" in out
    assert err.splitlines() == [f"warning: cache {path}: 1 damaged line skipped (line 2: no field 'success'); "
                                "its result is computed again"]
    assert JsonLinesStore(path, has_fields("success")).get("b") == {"success": True, "x": 2}


def test_results_of_other_code_are_not_reused(tmp_path, capsys):
    """A store stamped with the code version holds only that version's results: another version's are counted
    and computed again, and both stay in the file."""
    from drakeslip.jobs.runner import JsonLinesStore, run

    path = tmp_path / "cache.jsonl"
    assert dict(run(lambda x: x, [("a", (1,))], JsonLinesStore(path, stamp="git:old"))) == {"a": 1}
    capsys.readouterr()
    assert dict(run(lambda x: 10 * x, [("a", (1,))], JsonLinesStore(path, stamp="git:new"))) == {"a": 10}
    assert capsys.readouterr().out == f"cache {path}: 0 of 1 results reused; 1 made by other code ignored\n"
    assert JsonLinesStore(path, stamp="git:old").get("a") == 1 and JsonLinesStore(path, stamp="git:new").get("a") == 10


def test_written_files_respect_the_umask(tmp_path):
    from drakeslip.jobs.files import atomic_write

    old = os.umask(0o022)
    try:
        with atomic_write(tmp_path / "shared.json", "w") as f:
            f.write("{}")
    finally:
        os.umask(old)
    assert (tmp_path / "shared.json").stat().st_mode & 0o777 == 0o644
