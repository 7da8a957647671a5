"""The fast and the Drake step maps agree on random hops over step terrain (verification.backend_agreement)."""
import numpy as np
import pytest

import drakeslip as ds
from verification.backend_agreement import compare_backends, draw_cases

TOLERANCE = 2e-3  # m


@pytest.fixture(scope="module")
def report():
    return compare_backends(n_cases=100, seed=2026, families=("step",), tolerance=TOLERANCE)


def test_backends_agree_on_the_outcome(report):
    assert report.disagreement_rate <= 0.02, report.format()


def test_backends_agree_on_foothold_and_next_apex(report):
    assert len(report.both_ok) >= 15, report.format()  # enough successes for the comparison to mean something
    assert report.worst_touchdown_deviation <= TOLERANCE, report.format()
    assert report.worst_apex_deviation <= TOLERANCE, report.format()
    assert not report.beyond_tolerance


def test_cases_cover_several_outcomes_and_are_reproducible(report):
    assert len(report.outcomes) >= 3, report.outcomes
    assert draw_cases(5, seed=3, families=("step", "ditch")) == draw_cases(5, seed=3, families=("step", "ditch"))
    with pytest.raises(ValueError, match="unknown terrain families.*'hills'"):
        draw_cases(1, seed=0, families=("hills",))


def test_the_benchmarked_hops_succeed_and_agree():
    """The hop tests/test_bench_stepmap.py times (step_world(3), apex (0, 0.6, 2), leg angle 0.25) on both step maps,
    and its batch of 30 leg angles across the friction cone, of which several land."""
    terrain, params = ds.step_world(3), ds.SlipParams()
    fast, drake = (ds.step((0.0, 0.6, 2.0), 0.25, terrain, params, backend=b) for b in ("fast", "drake"))
    assert fast.ok and drake.ok
    assert abs(fast.touchdown_x - drake.touchdown_x) <= TOLERANCE
    angles = np.linspace(-params.max_leg_angle, params.max_leg_angle, 30)
    assert ds.step_batch((0.0, 0.6, 2.0), angles, terrain, params).ok.sum() >= 5
