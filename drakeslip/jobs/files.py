"""Atomic file writes, so a killed job or a reader never sees a half-written result, and the JSON-lines
caches that let long jobs resume."""
from __future__ import annotations

import json
import os
import tempfile
from contextlib import contextmanager
from pathlib import Path


@contextmanager
def atomic_write(path, mode: str = "wb"):
    """Yield a file open on a unique temporary name beside ``path``; when the block succeeds the file replaces
    ``path`` in one rename, when it fails the temporary file is removed and ``path`` is untouched."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name + ".", suffix=".tmp")
    try:
        os.fchmod(fd, 0o666 & ~_umask())  # mkstemp makes 0600; a result file gets the usual permissions
        with os.fdopen(fd, mode) as f:
            yield f
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def read_json(path, what: str):
    """The JSON document in ``path``; one that does not parse raises ValueError naming ``what`` and the file."""
    path = Path(path)
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ValueError(f"{what} {path} is not valid JSON: {exc}") from exc


def read_jsonl_cache(path, key_of, value_of) -> dict:
    """{key_of(entry): value_of(entry)} over the JSON lines of ``path`` (empty if it does not exist). A resumable
    job appends one line per finished item; a line cut short by a kill, one that is not UTF-8 JSON, or one missing
    a field is skipped."""
    cache = {}
    path = Path(path)
    if path.exists():
        for line in path.read_bytes().splitlines():
            try:
                entry = json.loads(line.decode("utf-8"))
                cache[key_of(entry)] = value_of(entry)
            except (UnicodeDecodeError, json.JSONDecodeError, KeyError, TypeError):
                continue
    return cache


def open_jsonl_cache(path):
    """Open a JSON-lines cache for appending, creating its folder. A last line cut short by a kill is ended
    first, so the next entry starts a line of its own instead of being lost with the fragment."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    sink = open(path, "a")
    if sink.tell() > 0:
        with open(path, "rb") as f:
            f.seek(-1, os.SEEK_END)
            if f.read(1) != b"\n":
                sink.write("\n")
    return sink


def append_jsonl(sink, entry) -> None:
    """Append one entry to an open JSON-lines cache and make it durable before going on."""
    sink.write(json.dumps(entry) + "\n")
    sink.flush()
    os.fsync(sink.fileno())
