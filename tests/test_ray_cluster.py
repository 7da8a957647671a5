"""The Ray executor (drakeslip.jobs.executors.RayCluster) on a real local multi-node Ray cluster: two nodes of one CPU
each (ray.cluster_utils.Cluster), which the executor joins itself, shipping our packages as runtime_env py_modules.
Each job gives the same per-case results as in this process: the evaluation harness, the model-checking oracle,
dataset generation (through examples/generate_dataset.py, whose shards must be the same files) and the ranker's
DAgger shards (whose tasks get their weights files as bytes)."""
import time

import numpy as np
import pytest

ray = pytest.importorskip("ray", reason="ray is not installed (pip install 'ray>=2.9'): the Ray executor is untested")

from ray.cluster_utils import Cluster  # noqa: E402

from drakeslip.jobs.executors import RayCluster  # noqa: E402
from planners.base import Budget  # noqa: E402
from planners.closed_loop import ClosedLoopConfig  # noqa: E402
from planners.formats.suite import make_suite  # noqa: E402

pytestmark = pytest.mark.slow

NODES = 2
TIMINGS = ("t_plan_s", "t_plan_mean_s", "t_plan_median_s", "time_s", "time_s_median", "seconds", "train_seconds",
           "timing", "timing_mean_s", "provenance")   # a run's provenance holds its date


@pytest.fixture(scope="module")
def address():
    """A running cluster of NODES one-CPU nodes, shut down after the module (with this process's connection)."""
    node = {"num_cpus": 1, "object_store_memory": 100 * 1024 ** 2}
    cluster = Cluster(initialize_head=True, head_node_args={**node, "include_dashboard": False})
    try:
        for _ in range(NODES - 1):
            cluster.add_node(**node)
        cluster.wait_for_nodes()
        yield cluster.address
    finally:
        ray.shutdown()
        cluster.shutdown()


@pytest.fixture(scope="module")
def suite():
    return make_suite("ditch", 7, 1)


def untimed(value):
    """``value`` without its wall-clock timings and its provenance, which differ from run to run."""
    if isinstance(value, dict):
        return {k: untimed(v) for k, v in value.items() if k not in TIMINGS}
    if isinstance(value, list):
        return [untimed(v) for v in value]
    return value


def test_tasks_run_on_every_node_with_our_packages_shipped(address):
    def where(i):
        time.sleep(1.0)  # long enough that the two tasks in flight overlap, one per one-CPU node
        context = ray.get_runtime_context()
        return context.get_node_id(), sorted(context.runtime_env.get("py_modules", []))

    results = dict(RayCluster(address, jobs=NODES).results(where, [(i, (i,)) for i in range(2 * NODES)]))
    assert sorted(results) == list(range(2 * NODES))
    assert sum(node["Alive"] for node in ray.nodes()) == NODES
    assert len({node for node, _ in results.values()}) == NODES
    assert all(len(modules) == 3 for _, modules in results.values())  # drakeslip, planners, verification


def test_evaluation_on_the_cluster_matches_this_process(address, suite):
    from verification.evaluation import evaluate

    def run(executor):
        return evaluate(suite, {"step": {}, "heuristic": {}}, n_cases=10, executor=executor,
                        config=ClosedLoopConfig(backend="fast"), progress=False)

    here, there = run(None), run(RayCluster(address, jobs=NODES))
    for label in ("step", "heuristic"):
        cases = here["planners"][label]["cases"]
        assert len(cases) == 10 and any(case["plans"] for case in cases)
        assert [case["id"] for case in there["planners"][label]["cases"]] == [case["id"] for case in cases]
        for mine, theirs in zip(cases, there["planners"][label]["cases"]):
            assert untimed(theirs) == untimed(mine), mine["id"]  # outcome, footholds, ODE calls, nodes per plan
    assert untimed(there) == untimed(here)


def test_oracle_on_the_cluster_matches_this_process(address, suite):
    from verification.model_check_suite import check_suite

    cases, budget = suite.cases[:2], Budget(max_nodes=20000, max_time_s=60.0)
    here = check_suite(suite, cases, None, budget, progress=False)
    there = check_suite(suite, cases, None, budget, progress=False, executor=RayCluster(address, jobs=NODES))
    assert [c["id"] for c in there["cases"]] == [c.id for c in cases]
    for mine, theirs in zip(here["cases"], there["cases"]):
        assert theirs["verdict"] == mine["verdict"] and theirs["witness"] == mine["witness"], mine["id"]
        assert untimed(theirs) == untimed(mine), mine["id"]
    assert here["summary"]["cases"] == 2


def test_dataset_generated_on_the_cluster_is_the_same_files(address, tmp_path, example):
    script = example("generate_dataset")
    tiny = ["--terrains", "2", "--apexes", "2", "--shard-size", "2", "--seed", "1", "--quiet"]
    script.main(["--out", str(tmp_path / "here"), "--jobs", "1", *tiny])
    script.main(["--out", str(tmp_path / "there"), "--executor", "ray", "--address", address, "--jobs", str(NODES),
                 *tiny])
    names = sorted(p.name for p in (tmp_path / "here").glob("shard_*.npz"))
    assert names == ["shard_00000.npz", "shard_00001.npz"]
    assert sorted(p.name for p in (tmp_path / "there").glob("shard_*.npz")) == names
    for name in names:
        with np.load(tmp_path / "here" / name) as a, np.load(tmp_path / "there" / name) as b:
            assert sorted(a.files) == sorted(b.files)
            for key in a.files:
                np.testing.assert_array_equal(a[key], b[key], err_msg=f"{name}: {key}")
        assert (tmp_path / "here" / name).read_bytes() == (tmp_path / "there" / name).read_bytes()
    assert (tmp_path / "here" / "config.json").read_text() == (tmp_path / "there" / "config.json").read_text()
    written = {name: (tmp_path / "there" / name).stat().st_mtime_ns for name in names}
    script.main(["--out", str(tmp_path / "there"), "--executor", "ray", "--address", address, *tiny])  # resumes
    assert {name: (tmp_path / "there" / name).stat().st_mtime_ns for name in names} == written


def test_ranker_shards_on_the_cluster_match_this_process(address):
    from drakeslip.jobs.runner import run
    from planners.checkpoints import EXPERT_WEIGHTS, RANKER_WEIGHTS
    from planners.learned.training.train_ranker import collect_shard

    weights, ranker = EXPERT_WEIGHTS.read_bytes(), RANKER_WEIGHTS.read_bytes()  # a later round: the learner picks
    tasks = [(seed, ("ditch", seed, 1, weights, ranker, 5, 5, 0.3)) for seed in (100000, 110000)]
    here = dict(run(collect_shard, tasks))
    there = dict(run(collect_shard, tasks, executor=RayCluster(address, jobs=NODES)))
    assert sorted(there) == sorted(here)
    for seed, (features, rooms) in here.items():
        assert len(rooms) > 0
        np.testing.assert_array_equal(there[seed][0], features)
        np.testing.assert_array_equal(there[seed][1], rooms)
