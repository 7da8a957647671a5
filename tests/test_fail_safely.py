"""Jobs fail safely: killing a parallel job leaves no worker behind, and a damaged cache line is skipped."""
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


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc").is_dir(), reason="reads the process table from /proc (Linux)")
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM, signal.SIGINT], ids=lambda s: s.name)
def test_killing_a_two_process_evaluation_leaves_no_worker(tmp_path, sig):
    job = subprocess.Popen([sys.executable, str(ROOT / "examples" / "evaluate.py"), "--suite",
                            str(ROOT / "suites" / "step.json"), "--planners", "step,angle", "--backend", "fast",
                            "--jobs", "2", "--quiet", "--out", str(tmp_path / "results.json")],
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    deadline = time.monotonic() + 120
    workers: set[int] = set()
    while time.monotonic() < deadline and len(workers) < 2:
        workers = {p for p in descendants(job.pid) if "spawn_main" in Path(f"/proc/{p}/cmdline").read_bytes()
                   .decode(errors="replace")} if alive(job.pid) else set()
        time.sleep(0.2)
    assert len(workers) >= 2, "the job did not start its two workers"
    time.sleep(2.0)  # the workers are busy with cases
    everyone = descendants(job.pid)
    os.kill(job.pid, sig)
    job.wait(timeout=60)
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and any(alive(p) for p in everyone):
        time.sleep(0.2)
    left = [p for p in everyone if alive(p)]
    for p in left:  # do not leave them to the next test
        os.kill(p, signal.SIGKILL)
    assert not left, f"processes left after {sig.name} of the parent: {left}"
    assert job.returncode != 0
    # what finished before the kill is in the cache, and a rerun resumes from it
    cache = Path(str(tmp_path / "results.json") + ".cases.jsonl")
    assert not cache.exists() or all(line.startswith('{"key"') for line in cache.read_text().splitlines()[:-1])


def test_a_cache_with_undecodable_bytes_resumes(tmp_path):
    from drakeslip.jobs.runner import JsonLinesStore

    path = tmp_path / "cache.jsonl"
    store = JsonLinesStore(path)
    store.put("a", {"value": 1})
    store.close()
    with open(path, "ab") as f:
        f.write(b"\xff\xfe not utf-8 \x80\n")
    store = JsonLinesStore(path)
    store.put("b", {"value": 2})
    store.close()
    again = JsonLinesStore(path)
    assert again.get("a") == {"value": 1} and again.get("b") == {"value": 2}


def test_written_files_respect_the_umask(tmp_path):
    from drakeslip.jobs.files import atomic_write

    old = os.umask(0o022)
    try:
        with atomic_write(tmp_path / "shared.json", "w") as f:
            f.write("{}")
    finally:
        os.umask(old)
    assert (tmp_path / "shared.json").stat().st_mode & 0o777 == 0o644
