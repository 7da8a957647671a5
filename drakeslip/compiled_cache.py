"""Numba's on-disk cache kept true to the sources it was compiled from.

numba's ``cache=True`` checks only the file that defines the cached function: a compiled search in
planners/core/grid.py keeps the step map of drakeslip/fast_step.py (and any global constant) it was compiled with
after that other file changes, so a checkout updated in place would plan with old code. Each package calls
``clear_when_sources_change`` on import, before any of its compiled functions loads: when the digest of every source
its compiled code can reach differs from the one stamped beside its cache, the package's cached machine code is
deleted and numba compiles anew. It covers numba's default cache, the ``__pycache__`` folders beside the sources; a
read-only install, whose cache numba keeps elsewhere, is not touched."""
from __future__ import annotations

import hashlib
import os
from pathlib import Path

STAMP = "numba-sources.sha256"


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
