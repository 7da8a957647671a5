"""The dataset generator's Ray executor, against a local Ray instance: same shards as the local pool."""
import os
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("ray")

SCRIPT = os.path.join(os.path.dirname(__file__), "..", "examples", "generate_dataset.py")
ARGS = ["--terrains", "2", "--apexes", "2", "--shard-size", "2", "--seed", "1"]


def run(out, *extra):
    proc = subprocess.run([sys.executable, SCRIPT, "--out", str(out), *ARGS, *extra], capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return proc.stdout


def test_ray_executor_matches_local_pool(tmp_path):
    run(tmp_path / "local", "--jobs", "1")
    out = run(tmp_path / "ray", "--executor", "ray")
    assert "sequences/s" in out
    names = sorted(f for f in os.listdir(tmp_path / "local") if f.endswith(".npz"))
    assert names and names == sorted(f for f in os.listdir(tmp_path / "ray") if f.endswith(".npz"))
    for name in names:
        a, b = np.load(tmp_path / "local" / name), np.load(tmp_path / "ray" / name)
        for key in ("terrain", "apex", "s0", "steps"):
            np.testing.assert_array_equal(a[key], b[key])
