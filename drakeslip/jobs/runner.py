"""The one way long jobs run: keyed tasks on an executor, each result saved by the driver as it arrives, so a
killed job resumes where it stopped.

A task is ``(key, args)``; ``key`` names what the result depends on (a case, a solve, a shard) and is what a
store finds it by. ``run`` yields ``(key, result)`` for every task: first those the store already holds (and
``reuse`` accepts), then the others as the executor finishes them. Only the driver writes, so the workers need
no filesystem of their own (see ``executors``).
"""
from __future__ import annotations

import json
import math
import os
from pathlib import Path

from drakeslip.jobs.executors import InProcess
from drakeslip.jobs.files import append_jsonl, atomic_write, open_jsonl_cache, read_jsonl_cache


class JsonLinesStore:
    """Results as JSON lines ``{"key": key, "result": result}`` in one file, appended and made durable one at a
    time; a line cut short by a kill or one that does not decode is skipped when read back."""

    def __init__(self, path):
        self.path = Path(path)
        self._held = read_jsonl_cache(self.path, lambda e: e["key"], lambda e: e["result"])
        self._sink = None

    def get(self, key):
        return self._held.get(key)

    def put(self, key, result) -> None:
        if self._sink is None:
            self._sink = open_jsonl_cache(self.path)
        append_jsonl(self._sink, {"key": key, "result": result})
        self._held[key] = result

    def close(self) -> None:
        if self._sink is not None:
            self._sink.close()
            self._sink = None


class FileStore:
    """One file per result in a folder, ``name(key)`` its file name, written atomically by ``write(path, result)``;
    a result that is on disk is reused as ``read(path)`` (None: only that it exists is known)."""

    def __init__(self, folder, name, write, read=None):
        self.folder = Path(folder)
        self.name, self.write, self.read = name, write, read

    def path(self, key) -> Path:
        return self.folder / self.name(key)

    def get(self, key):
        path = self.path(key)
        if not path.exists():
            return None
        return self.read(path) if self.read else str(path)

    def put(self, key, result) -> None:
        self.folder.mkdir(parents=True, exist_ok=True)
        self.write(self.path(key), result)

    def close(self) -> None:
        pass


def run(fn, tasks, store=None, executor=None, setup=None, reuse=None):
    """Yield ``(key, result)`` for each ``(key, args)`` of ``tasks``: a stored result when ``store`` holds one that
    ``reuse(result)`` accepts (default: any), else ``fn(*args)`` run by ``executor`` (default: in this process,
    with ``setup`` as there) and put in the store before it is yielded."""
    executor = executor or InProcess()
    todo = []
    try:
        for key, args in tasks:
            held = store.get(key) if store is not None else None
            if held is not None and (reuse is None or reuse(held)):
                yield key, held
            else:
                todo.append((key, args))
        for key, result in executor.results(fn, todo, setup):
            if store is not None:
                store.put(key, result)
            yield key, result
    finally:
        if store is not None:
            store.close()


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
