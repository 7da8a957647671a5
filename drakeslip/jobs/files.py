"""Atomic file writes, so a killed job or a reader never sees a half-written result, and the JSON-lines
caches that let long jobs resume."""
from __future__ import annotations

import hashlib
import json
import os
import tempfile
from contextlib import contextmanager
from pathlib import Path

MANIFEST = "SHA256SUMS"  # beside committed weights: "<sha256>  <file name>" lines, as sha256sum writes them


@contextmanager
def atomic_write(path, mode: str = "wb"):
    """Yield a file open on a unique temporary name beside ``path``; when the block succeeds the file replaces
    ``path`` in one rename, when it fails the temporary file is removed and ``path`` is untouched. A write that
    fails (a full disk) raises its OSError naming ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name + ".", suffix=".tmp")
    try:
        os.fchmod(fd, 0o666 & ~_umask())  # mkstemp makes 0600; a result file gets the usual permissions
        with os.fdopen(fd, mode) as f:
            yield f
        os.replace(tmp, path)
    except BaseException as error:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise naming(error, path)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def read_json(path, what: str):
    """The JSON document in ``path``; one that does not parse raises ValueError naming ``what`` and the file."""
    path = Path(path)
    try:
        text = path.read_text()
    except UnicodeDecodeError as exc:
        raise ValueError(f"{what} {path} is not JSON: not UTF-8 text ({exc.reason} at byte {exc.start})") from exc
    return parse_json(text, f"{what} {path}")


class DuplicateKey(ValueError):
    """A JSON object that gives one key twice."""


def unique_keys(pairs: list) -> dict:
    """A JSON object's pairs as a dict; DuplicateKey for a key given twice (the parser would keep the last silently,
    and which one the writer meant is not for the reader to guess)."""
    out = {}
    for key, value in pairs:
        if key in out:
            raise DuplicateKey(f"the key {key!r} is given twice in one object")
        out[key] = value
    return out


def parse_json(text: str, what: str):
    """The JSON document ``text`` (a file's, or an option's given on a command line); one that does not parse, gives
    a key twice in an object, or is nested too deeply for the parser, raises ValueError naming ``what``, in one
    line."""
    try:
        return json.loads(text, object_pairs_hook=unique_keys)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{what} is not valid JSON: {exc}") from exc
    except DuplicateKey as exc:
        raise ValueError(f"{what}: {exc}") from None
    except RecursionError:
        raise ValueError(f"{what} is nested too deeply to read as JSON") from None


def known_fields(d: dict, fields, where: str) -> None:
    """ValueError naming the first key of the JSON object ``d`` that is not one of ``fields``: a field the reader does
    not know would be ignored without a word (a suite case's own goal_x, a misspelt one)."""
    unknown = [key for key in d if key not in fields]
    if unknown:
        raise ValueError(f"{where}: unknown field {unknown[0]!r} (the fields are {', '.join(fields)})")


def read_jsonl_cache(path, key_of, value_of, skipped: list | None = None) -> dict:
    """{key_of(entry): value_of(entry)} over the JSON lines of ``path`` (empty if it does not exist). A resumable
    job appends one line per finished item; a line cut short by a kill, one that is not UTF-8 JSON, or one that
    ``key_of`` or ``value_of`` refuses (KeyError, TypeError or ValueError: a missing or bad field) is skipped,
    and ``(line number, why)`` appended to ``skipped`` when given."""
    cache, skipped = {}, [] if skipped is None else skipped
    path = Path(path)
    if path.exists():
        for number, line in enumerate(path.read_bytes().splitlines(), start=1):
            if not line.strip():
                continue
            try:
                entry = json.loads(line.decode("utf-8"))
                cache[key_of(entry)] = value_of(entry)
            except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
                why = "not UTF-8 JSON"
                if isinstance(exc, json.JSONDecodeError) and exc.pos >= len(line.rstrip()):
                    why = "cut short"
                skipped.append((number, why))
            except KeyError as exc:
                skipped.append((number, f"no field {exc}"))
            except (TypeError, ValueError) as exc:
                skipped.append((number, str(exc) or type(exc).__name__))
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
    """Append one entry to an open JSON-lines cache and make it durable before going on; a write that fails (a full
    disk) raises its OSError naming the cache (a line it cut short is skipped when the cache is read)."""
    try:
        sink.write(json.dumps(entry) + "\n")
        sink.flush()
        os.fsync(sink.fileno())
    except OSError as error:
        raise naming(error, sink.name)


def naming(error: BaseException, path) -> BaseException:
    """``error``, or for an OSError of a write that names no file (a full disk), the same error naming ``path``."""
    if isinstance(error, OSError) and error.filename is None and error.errno is not None:
        return OSError(error.errno, error.strerror, str(path))
    return error


def sha256(path) -> str:
    """The SHA-256 of a file's bytes, in hex."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def manifest_entries(folder) -> dict:
    """{file name: sha256} from ``folder``'s manifest (empty without one)."""
    path = Path(folder) / MANIFEST
    if not path.is_file():
        return {}
    entries = {}
    for line in path.read_text().splitlines():
        digest, _, name = line.strip().partition("  ")
        if digest and name:
            entries[name] = digest
    return entries


def check_digest(path) -> bool:
    """Verify a weights file against the manifest of its folder. Returns True when the manifest lists it and the
    digest matches, False when no manifest lists it (a user's own file: its loader checks its structure); a
    mismatch raises ValueError naming the file (changed or damaged since the manifest was written)."""
    path = Path(path)
    expected = manifest_entries(path.parent).get(path.name)
    if expected is None:
        return False
    actual = sha256(path)
    if actual != expected:
        raise ValueError(f"weights file {path} does not match its SHA-256 in {path.parent / MANIFEST} "
                         f"(expected {expected[:16]}..., got {actual[:16]}...): it was changed or damaged")
    return True


def load_weights(path, what: str):
    """The tensors and plain data of a torch weights file (``weights_only``), after ``check_digest``; a file that
    torch cannot read raises ValueError naming ``what`` and the file (torch's warnings about a foreign file are
    not shown: the error says it)."""
    import warnings

    import torch

    check_digest(path)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return torch.load(path, map_location="cpu", weights_only=True)
    except FileNotFoundError:
        raise
    except Exception as exc:  # torch raises many types for a damaged file
        why = first_line(exc)
        if why.startswith("Weights only load failed"):   # torch's advice to unpickle anything does not apply
            why = "not a torch file of tensors and plain data"
        raise ValueError(f"cannot read {what} {path}: {why}") from exc


def first_line(error: BaseException) -> str:
    """An exception's message cut to its first line (torch's loader explains itself over a dozen lines)."""
    text = str(error).strip()
    return text.splitlines()[0] if text else type(error).__name__


MESSAGE_LIMIT = 1000   # characters of a message line: a few paths and values, never a whole file echoed back


def printable(text: str, limit: int = MESSAGE_LIMIT) -> str:
    """``text`` fit for one line of a terminal: cut to ``limit`` characters (saying how many it had), every
    character that is not printable (a newline, an escape sequence, a NUL) written as its escape, ``\\x1b``."""
    text = str(text)
    if len(text) > limit:
        text = f"{text[:limit]}... ({len(text)} characters)"
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def record_digest(path) -> None:
    """After writing a weights file: update its entry in the manifest of its folder, if the folder has one."""
    path = Path(path)
    manifest = path.parent / MANIFEST
    if not manifest.is_file():
        return
    entries = {**manifest_entries(path.parent), path.name: sha256(path)}
    with atomic_write(manifest, "w") as f:
        f.write("".join(f"{digest}  {name}\n" for name, digest in sorted(entries.items())))
