"""The one way long jobs run: keyed tasks on an executor, each result saved by the driver as it arrives, so a
killed job resumes where it stopped.

A task is ``(key, args)``; ``key`` names what the result depends on (a case, a solve, a shard, and the code
version that computes it) and is what a store finds it by. ``run`` yields ``(key, result)`` for every task:
first those the store already holds (and ``reuse`` accepts), then the others as the executor finishes them.
Only the driver writes, so the workers need no filesystem of their own (see ``executors``).
"""
from __future__ import annotations

import json
import math
import os
import sys
from pathlib import Path

from drakeslip.jobs.executors import InProcess
from drakeslip.jobs.files import append_jsonl, atomic_write, open_jsonl_cache, printable, read_jsonl_cache


class JsonLinesStore:
    """Results as JSON lines ``{"key": key, "result": result}`` in one file, appended and made durable one at a
    time. With a ``stamp`` (the code version that makes the results) each line carries it as ``"stamp"`` and only
    the lines of the same stamp are held; the others are counted in ``foreign``. A line cut short by a kill, one
    that does not decode, or one whose result ``check`` refuses (KeyError, TypeError or ValueError: a missing field,
    a field of the wrong type; ``has_fields`` makes a check of fields present) is skipped and listed in ``skipped``
    as ``(line number, why)``: its result is computed again."""

    def __init__(self, path, check=None, stamp: str | None = None):
        self.path = self.where = Path(path)
        self.check, self.stamp = check, stamp
        self.skipped: list = []
        read = read_jsonl_cache(self.path, self._stamped_key, self._checked, self.skipped)
        self._held = {key: result for (ours, key), result in read.items() if ours}
        self.foreign = len(read) - len(self._held)
        self._sink = None

    def _stamped_key(self, entry) -> tuple:
        """(whether the line is of this store's stamp, its key: a string)."""
        if not isinstance(entry, dict):
            raise TypeError(f"the line is {type(entry).__name__}, not an object")
        if not isinstance(entry["key"], str):
            raise TypeError(f"key must be a string, got {type(entry['key']).__name__}")
        return self.stamp is None or entry.get("stamp") == self.stamp, entry["key"]

    def _checked(self, entry):
        """The line's result, after ``check``."""
        result = entry["result"]
        if self.check is not None:
            self.check(result)
        return result

    def get(self, key):
        return self._held.get(key)

    def count_saved(self, keys) -> int:
        """How many of ``keys`` have a result of this stamp in the file now (read again: the file is the truth
        when a put was interrupted)."""
        on_disk = JsonLinesStore(self.path, self.check, self.stamp)
        return sum(on_disk.get(key) is not None for key in set(keys))

    def put(self, key, result) -> None:
        if self._sink is None:
            self._sink = open_jsonl_cache(self.path)
        stamp = {} if self.stamp is None else {"stamp": self.stamp}
        append_jsonl(self._sink, {"key": key, **stamp, "result": result})
        self._held[key] = result

    def close(self) -> None:
        if self._sink is not None:
            self._sink.close()
            self._sink = None


def has_fields(*names: str):
    """A ``JsonLinesStore`` check: the result is an object with each of ``names`` (KeyError naming the first it
    lacks)."""
    def check(result) -> None:
        for name in names:
            if not isinstance(result, dict) or name not in result:
                raise KeyError(name)
    return check


class FileStore:
    """One file per result in a folder, ``name(key)`` its file name, written atomically by ``write(path, result)``;
    a result that is on disk is reused as ``read(path)`` (None: only that it exists is known)."""

    def __init__(self, folder, name, write, read=None):
        self.folder = self.where = Path(folder)
        self.name, self.write, self.read = name, write, read

    def path(self, key) -> Path:
        return self.folder / self.name(key)

    def get(self, key):
        path = self.path(key)
        if not path.exists():
            return None
        return self.read(path) if self.read else str(path)

    def count_saved(self, keys) -> int:
        """How many of ``keys`` have a result file."""
        return sum(self.path(key).exists() for key in set(keys))

    def put(self, key, result) -> None:
        self.folder.mkdir(parents=True, exist_ok=True)
        self.write(self.path(key), result)

    def close(self) -> None:
        pass


# The run of this process in progress, or its last one, if it has a store: the store and the keys of its tasks.
# An interrupted script reports what the store holds of them (``saved_so_far``).
_PROGRESS: dict = {}


def run(fn, tasks, store=None, executor=None, setup=None, reuse=None):
    """Yield ``(key, result)`` for each ``(key, args)`` of ``tasks``: a stored result when ``store`` holds one that
    ``reuse(result)`` accepts (default: any), else ``fn(*args)`` run by ``executor`` (default: in this process,
    with ``setup`` as there) and put in the store before it is yielded. What the store held is said first: one
    line on stdout when results are reused or the store holds results of other code, a warning on stderr when it
    skipped damaged lines."""
    executor = executor or InProcess()
    tasks = list(tasks)
    held = {}
    _PROGRESS.clear()
    if store is not None:
        for key, _ in tasks:
            result = store.get(key)
            if result is not None and (reuse is None or reuse(result)):
                held[key] = result
        report_store(store, len(held), len(tasks))
        _PROGRESS.update(store=store, keys=[key for key, _ in tasks])
    try:
        for key, _ in tasks:
            if key in held:
                yield key, held[key]
        for key, result in executor.results(fn, [task for task in tasks if task[0] not in held], setup):
            if store is not None:
                store.put(key, result)
            yield key, result
    finally:
        if store is not None:
            store.close()


def report_store(store, reused: int, total: int) -> None:
    """Say what ``store`` held for a run of ``total`` tasks of which ``reused`` are taken from it."""
    foreign, skipped = getattr(store, "foreign", 0), getattr(store, "skipped", [])
    if reused or foreign:
        other = f"; {foreign} made by other code ignored" if foreign else ""
        print(f"cache {store.where}: {reused} of {total} results reused{other}", flush=True)
    if skipped:
        (line, why), n = skipped[0], len(skipped)
        lines = "1 damaged line" if n == 1 else f"{n} damaged lines"
        print(printable(f"warning: cache {store.where}: {lines} skipped (line {line}: {why}); "
                        f"{'its result is' if n == 1 else 'their results are'} computed again"),
              file=sys.stderr, flush=True)


def saved_so_far() -> str | None:
    """What the run in progress (or the last run) of this process saved: "37 of 150 results saved in PATH", or
    None when no run with a store started."""
    if not _PROGRESS:
        return None
    store, keys = _PROGRESS["store"], _PROGRESS["keys"]
    return f"{store.count_saved(keys)} of {len(set(keys))} results saved in {store.where}"


def write_json(path, document, indent: int | None = 1) -> None:
    """Write ``document`` atomically (a temporary file renamed over ``path``) as strict JSON: a non-finite number
    (an absent margin, an undefined mean) is written as null."""
    with atomic_write(path, "w") as f:
        json.dump(finite(document), f, indent=indent, allow_nan=False)
        f.write("\n")


def finite(value):
    """``value`` with every non-finite float, however deeply nested, replaced by None (JSON has no inf or NaN)."""
    if isinstance(value, dict):
        return {k: finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def remove(path) -> None:
    """Delete ``path`` if it exists (a store a user asked to start over)."""
    if os.path.exists(path):
        os.unlink(path)
