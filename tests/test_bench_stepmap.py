"""Step-map benchmarks, side by side in one group: fast single step, fast batch of 30 angles, Drake step; the Drake
step reports its time over the fast backend's per step in a batch (``fast_speedup`` in its extra info). Timing
only: the hop they time is checked on both step maps in tests/test_agreement.py.

    python3 -m pytest --benchmark-only -q tests/test_bench_stepmap.py
"""

import numpy as np
import pytest

import drakeslip as ds
from verification.backend_agreement import best_time

APEX = (0.0, 0.6, 2.0)
ANGLE = 0.25
N_ANGLES = 30
PARAMS = ds.SlipParams()
TERRAIN = ds.step_world(3)
ANGLES = np.linspace(-PARAMS.max_leg_angle, PARAMS.max_leg_angle, N_ANGLES)


def fast_batch():
    return ds.step_batch(APEX, ANGLES, TERRAIN, PARAMS)


@pytest.fixture(scope="module", autouse=True)
def compiled():
    fast_batch()  # load the compiled kernel before any timing


@pytest.mark.benchmark(group="stepmap")
def test_fast_single_step(benchmark):
    benchmark(ds.step, APEX, ANGLE, TERRAIN, PARAMS)


@pytest.mark.benchmark(group="stepmap")
def test_fast_batch_of_30_angles(benchmark):
    benchmark(fast_batch)
    if benchmark.stats:  # absent under --benchmark-disable
        benchmark.extra_info["us_per_step"] = benchmark.stats.stats.median / N_ANGLES * 1e6


@pytest.mark.benchmark(group="stepmap")
def test_drake_step(benchmark):
    benchmark.pedantic(ds.step, args=(APEX, ANGLE, TERRAIN, PARAMS), kwargs={"backend": "drake"},
                       rounds=3, iterations=1)
    # Side by side in this process: Drake against the fast backend's per-step time in a batch.
    drake = benchmark.stats.stats.min if benchmark.stats else best_time(
        lambda: ds.step(APEX, ANGLE, TERRAIN, PARAMS, backend="drake"), 2)
    benchmark.extra_info["fast_speedup"] = drake / (best_time(fast_batch, 200) / N_ANGLES)
