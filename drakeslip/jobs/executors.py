"""Where independent tasks run: in this process, in spawned local worker processes, or on a Ray cluster.

Every executor yields ``(tag, fn(*args))`` for the ``(tag, args)`` tasks it is given, as they finish, and sends
results back to the caller: nothing assumes a filesystem shared with the workers. A ``setup`` pair
``(initializer, initargs)`` runs in each worker process before its first task (loading weights, building
planners), and again only when a different setup ran there since, so a task can use what it left in module state.

Local workers are spawned, not forked (a child forked while torch or numba threads run can deadlock), use one
BLAS/OpenMP thread each, and die with the process that started them: a SIGKILL of the parent reaches them
through the kernel's parent-death signal, and a SIGTERM or SIGINT of the parent terminates them before it exits.
They ignore SIGINT themselves: a terminal's Ctrl-C reaches the whole process group, and the parent ends them
(a worker's own KeyboardInterrupt would print a traceback of its own). Tasks in flight on Ray are cancelled
when the caller stops early (an error, Ctrl-C).
"""
from __future__ import annotations

import os
import pickle
import signal
import threading

EXECUTORS = ("local", "ray")
PACKAGES = ("drakeslip", "planners", "verification")  # shipped to Ray workers
_LAST_SETUP: list = [None]   # the setup this process ran last: what module state holds now


def prepare(setup) -> None:
    """Run ``setup = (initializer, initargs)`` in this process unless it is the one that ran here last (a setup
    leaves its state in module globals, so another one run since has replaced it)."""
    if setup is None:
        return
    key = pickle.dumps(setup)
    if key != _LAST_SETUP[0]:
        setup[0](*setup[1])
        _LAST_SETUP[0] = key


def call(setup, fn, tag, args):
    """One task in a worker: the setup first if this process has not run it, then ``(tag, fn(*args))``."""
    prepare(setup)
    return tag, fn(*args)


class InProcess:
    """Tasks one after another in this process, in order."""

    jobs = 1

    def results(self, fn, tasks, setup=None):
        for tag, args in tasks:
            yield call(setup, fn, tag, args)


class LocalProcesses:
    """Tasks in ``jobs`` spawned worker processes on this machine."""

    def __init__(self, jobs: int):
        if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
            raise ValueError(f"jobs must be a positive integer, got {jobs!r}")
        self.jobs = jobs

    def results(self, fn, tasks, setup=None):
        import multiprocessing as mp

        tasks = list(tasks)
        if not tasks:
            return
        for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
            os.environ.setdefault(var, "1")  # inherited by the workers: one process per core, no thread spinning
        others = set(mp.active_children())
        pool = mp.get_context("spawn").Pool(min(self.jobs, len(tasks)), initializer=_die_with_parent,
                                            initargs=(os.getpid(),))
        workers = [p for p in mp.active_children() if p not in others]
        previous = _terminate_on_sigterm()
        try:
            results = pool.imap_unordered(_star_call, [(setup, fn, tag, args) for tag, args in tasks])
            for _ in tasks:
                while True:  # a worker that dies (killed, out of memory) takes its task with it: the pool would
                    try:     # wait for that result forever, so it is an error
                        tag, result = results.next(timeout=1.0)
                        break
                    except mp.TimeoutError:
                        dead = [p.exitcode for p in workers if p.exitcode is not None]
                        if dead:
                            from concurrent.futures.process import BrokenProcessPool

                            raise BrokenProcessPool(f"a worker process died (exit code {dead[0]}) while tasks "
                                                    f"were running; its task is lost") from None
                yield tag, result
        finally:
            pool.terminate()  # on success the workers are idle; on an error or a signal they must not run on
            pool.join()
            if previous is not None:
                signal.signal(signal.SIGTERM, previous)


class RayCluster:
    """Tasks on a Ray cluster: ``address`` of a running one (``"auto"``, ``"ray://host:10001"``, ...) or None for a
    local instance. At most ``jobs`` tasks are in flight (default: the cluster's CPUs). Our packages travel with
    the tasks (``runtime_env`` py_modules), so the nodes need only the dependencies installed."""

    def __init__(self, address: str | None = None, jobs: int | None = None):
        if jobs is not None and (isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1):
            raise ValueError(f"jobs must be a positive integer, got {jobs!r}")
        self.address, self.jobs = address, jobs

    def results(self, fn, tasks, setup=None):
        import ray

        if not ray.is_initialized():
            ray.init(address=self.address, log_to_driver=False, include_dashboard=False,
                     runtime_env={"py_modules": toolkit_packages()})
        remote = ray.remote(num_cpus=1)(call)
        limit = self.jobs or max(1, int(ray.cluster_resources().get("CPU", 1)))
        todo, running = list(tasks)[::-1], []
        try:
            while todo or running:
                while todo and len(running) < limit:
                    tag, args = todo.pop()
                    running.append(remote.remote(setup, fn, tag, args))
                done, running = ray.wait(running, num_returns=1)
                yield ray.get(done[0])
        finally:
            for ref in running:   # stopped early: no task runs on for nobody
                ray.cancel(ref, force=True)


def toolkit_packages() -> list[str]:
    """The folders of the toolkit's packages installed here (found, not imported: this module sits below them)."""
    import importlib.util

    found = []
    for name in PACKAGES:
        spec = importlib.util.find_spec(name)
        if spec is not None and spec.submodule_search_locations:
            found.append(list(spec.submodule_search_locations)[0])
    return found


def make_executor(kind: str = "local", jobs: int = 1, address: str | None = None):
    """The executor of a job: ``"local"`` (``jobs`` processes; 1: this process) or ``"ray"`` (``jobs`` tasks in
    flight on the cluster at ``address``)."""
    if kind == "local":
        if address is not None:
            raise ValueError("an address is for the ray executor; the local executor runs on this machine")
        return InProcess() if jobs == 1 else LocalProcesses(jobs)
    if kind == "ray":
        return RayCluster(address, jobs)
    raise ValueError(f"executor must be one of {EXECUTORS}, got {kind!r}")


def _star_call(packed):
    return call(*packed)


def _die_with_parent(parent: int) -> None:
    """Worker start: end this process when the parent dies, however it dies; leave Ctrl-C to the parent."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG: the kernel kills us when the parent thread exits
    except (OSError, AttributeError):
        pass  # not Linux: the watchdog below covers it
    if os.getppid() != parent:  # the parent died before the signal was armed
        os._exit(1)

    def watch():
        while os.getppid() == parent:
            threading.Event().wait(1.0)
        os._exit(1)

    threading.Thread(target=watch, daemon=True).start()


def _terminate_on_sigterm():
    """In the main thread, make SIGTERM raise SystemExit so the pool's cleanup runs; returns the old handler."""
    if threading.current_thread() is not threading.main_thread():
        return None

    def stop(signum, frame):
        raise SystemExit(128 + signum)

    return signal.signal(signal.SIGTERM, stop)
