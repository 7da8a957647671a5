"""How the toolkit's compiled code is compiled and kept.

``compiled`` is numba's ``njit`` with the options every compiled function here shares: machine code cached on disk,
and no C function-pointer wrapper (no compiled code here takes a function as a pointer; the wrapper doubles what
numba compiles for a function taking the core's tuples of arrays). A machine's first run compiles everything it
calls, so what costs compile time is kept out of it: a helper of one or two compiled callers is inlined into them
(``inline="always"``: one compiled unit instead of a function with its own entry points and machine code), a
counter passed on starts as ``np.int64`` (a literal argument compiles a second copy of the callee), read-only and
writable arrays are not mixed in one argument, and elements are assigned one by one where a slice or a mask
assignment would compile numba's shape checks and their messages.

numba's ``cache=True`` checks only the file that defines the cached function: a compiled search in
planners/core/grid.py keeps the step map of drakeslip/fast_step.py (and any global constant) it was compiled with
after that other file changes, so a checkout updated in place would plan with old code. Each package calls
``clear_when_sources_change`` on import, before any of its compiled functions loads: when the digest of every source
its compiled code can reach differs from the one stamped beside its cache, the package's cached machine code is
deleted and numba compiles anew. It covers numba's default cache, the ``__pycache__`` folders beside the sources; a
read-only install, whose cache numba keeps elsewhere, is not touched."""
from __future__ import annotations

import contextlib
import hashlib
import os
import sys
import threading
import time
from pathlib import Path

STAMP = "numba-sources.sha256"
ANNOUNCE_AFTER_S = 1.0   # loading machine code from the cache takes milliseconds; compiling it, seconds


def sources_digest(roots) -> str:
    """SHA-256 of every ``.py`` file under the given folders, names and contents, in a fixed order."""
    digest = hashlib.sha256()
    for root in map(Path, roots):
        for path in sorted(p for p in root.rglob("*.py") if "__pycache__" not in p.parts):
            digest.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


def clear_when_sources_change(package_dir, sources) -> bool:
    """Delete ``package_dir``'s cached numba code (``*.nbi``, ``*.nbc``) unless it was compiled from ``sources`` as
    they are now; returns whether it deleted. Concurrent callers agree: each writes the same stamp atomically."""
    package_dir = Path(package_dir)
    digest = sources_digest(sources)
    stamp = package_dir / "__pycache__" / STAMP
    try:
        if stamp.read_text() == digest:
            return False
    except OSError:
        pass
    try:
        for cache in package_dir.rglob("__pycache__"):
            for compiled in (*cache.glob("*.nbi"), *cache.glob("*.nbc")):
                compiled.unlink(missing_ok=True)
        stamp.parent.mkdir(exist_ok=True)
        written = stamp.with_name(f"{STAMP}.{os.getpid()}")
        written.write_text(digest)
        os.replace(written, stamp)
    except OSError:  # a read-only install: numba caches elsewhere, and nothing here was compiled
        return False
    return True


def compiled(**options):
    """numba's ``njit`` decorator as the toolkit compiles (cached, no C function-pointer wrapper), with ``options``
    (``fastmath``, ``parallel``, ...) added. numba is imported here, not with this module: ``import drakeslip``
    stays light."""
    from numba import njit

    return njit(cache=True, no_cfunc_wrapper=True, **options)


class Announcer:
    """Says once per process, in one line on stderr, that the toolkit's code is being compiled, when a ``compiling``
    block has run ANNOUNCE_AFTER_S. One daemon thread per process watches the open block: entering and leaving a
    block costs a lock, not a thread's start (a plan's search enters one per attempt, and a thread's start would cost
    a fast plan a tenth of its time)."""

    def __init__(self):
        self.reset()
        os.register_at_fork(after_in_child=self.reset)   # a fork copies no thread, and maybe a lock held by one

    def reset(self):
        self.condition = threading.Condition()
        self.since, self.depth, self.started = None, 0, False   # since: when the outermost open block began

    def enter(self):
        with self.condition:
            if not self.started:   # first use in this process
                self.started = True
                threading.Thread(target=self.watch, daemon=True).start()
            if self.depth == 0:
                self.since = time.monotonic()
            self.depth += 1
            self.condition.notify()

    def leave(self):
        with self.condition:
            self.depth -= 1
            if self.depth == 0:
                self.since = None

    def watch(self):
        with self.condition:
            while True:
                if self.since is None:
                    self.condition.wait()
                    continue
                left = self.since + ANNOUNCE_AFTER_S - time.monotonic()
                if left > 0:
                    self.condition.wait(left)
                    continue
                print("compiling the planning code for this machine, once (later runs load it from numba's cache) ...",
                      file=sys.stderr, flush=True)
                return


_announcer = Announcer()


@contextlib.contextmanager
def compiling():
    """Run the block (a first call of compiled code) saying in one line on stderr, once per process, that the
    toolkit's code is being compiled when it takes longer than ANNOUNCE_AFTER_S: on a machine's first run numba
    compiles it (tens of seconds), later runs load it from the cache in milliseconds (``Announcer``)."""
    _announcer.enter()
    try:
        yield
    finally:
        _announcer.leave()
