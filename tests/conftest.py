"""Shared test fixtures."""
import importlib.util
import signal
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.fixture
def example():
    """Loads examples/NAME.py as a module, so a test can call its functions and ``main`` in-process (the
    examples are scripts, not a package)."""
    def load(name: str):
        spec = importlib.util.spec_from_file_location(f"{name}_example", EXAMPLES / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module
    return load


@pytest.fixture
def run_script(example, capsys):
    """Runs examples/NAME.py's ``main`` in this process with the given arguments; returns (exit status, stdout,
    stderr). A usage error's SystemExit gives its status."""
    def run(name: str, *args):
        module = example(name)
        try:
            code = module.main([str(a) for a in args])
        except SystemExit as stop:
            code = stop.code
        captured = capsys.readouterr()
        return code, captured.out, captured.err
    return run


def pytest_configure(config):
    """Ctrl-C as a program started from a terminal takes it: a shell without job control starts a background command
    (``pytest ... &``) with SIGINT ignored, which every script a test starts would inherit, so the tests that
    interrupt a run would see it run to the end. A handled signal is reset to its default action in a child."""
    signal.signal(signal.SIGINT, signal.default_int_handler)


def pytest_collection_modifyitems(config, items):
    """Timing benchmarks run only with --benchmark-only: a plain run leaves them out, so it tests, not times."""
    if config.getoption("benchmark_only", False):
        return
    benchmarks = [item for item in items if "benchmark" in getattr(item, "fixturenames", ())]
    if benchmarks:
        config.hook.pytest_deselected(items=benchmarks)
        items[:] = [item for item in items if item not in benchmarks]
