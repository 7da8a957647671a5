"""Where a result came from: the code, the libraries, the machine and the date, recorded in every results JSON.

``provenance()`` is cheap (well under a second): library versions are read from the installed packages'
metadata (``importlib.metadata``), never by importing torch or pydrake, and git is asked with a timeout.
``code_version()`` names the code itself (the commit and a digest of uncommitted changes): the cached results
of the evaluation and the trajectory-optimization sweeps are keyed by it, so results of other code are never
reused, and the provenance of a results file gives the version its per-case results were computed with.
``weights_digests`` gives the SHA-256 of each weights file a planner read, so a retrained model shows in the
results of any run that used it.
"""
from __future__ import annotations

import datetime
import hashlib
import os
import platform
import subprocess
import sys
from importlib import metadata
from pathlib import Path

from drakeslip.jobs.files import sha256

ROOT = Path(__file__).resolve().parents[1]   # the repository (or source tree) the package runs from
GIT_TIMEOUT_S = 5.0
LIBRARIES = {"drake": "drake", "torch": "torch", "numpy": "numpy"}   # key in "versions" -> distribution name
PACKAGES = ("drakeslip", "planners", "verification")   # the code a result depends on, outside a git checkout


def _version(distribution: str) -> str | None:
    try:
        return metadata.version(distribution)
    except metadata.PackageNotFoundError:
        return None


def _git(*args: str, text: bool = True):
    """The output of ``git args`` in ROOT (stripped text, or bytes), None when git is missing, ROOT is not the top
    of a git checkout (an installed copy inside some other repository is not one), or git fails or hangs."""
    try:
        top = subprocess.run(["git", "rev-parse", "--show-toplevel"], cwd=ROOT, capture_output=True, text=True,
                             timeout=GIT_TIMEOUT_S)
        if top.returncode != 0 or Path(top.stdout.strip()).resolve() != ROOT:
            return None
        run = subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=text, timeout=GIT_TIMEOUT_S)
    except (OSError, subprocess.TimeoutExpired):
        return None
    if run.returncode != 0:
        return None
    return run.stdout.strip() if text else run.stdout


def code_version() -> str:
    """What code runs, as one string: ``git:COMMIT`` in a git checkout whose tracked files are as committed,
    ``git:COMMIT+DIGEST`` when they differ (DIGEST: of ``git diff --binary HEAD`` and of the files in the
    packages that git does not track yet and does not ignore, so two different sets of uncommitted changes
    differ; other untracked files, such as outputs and caches, are not code), and
    ``source:DIGEST`` of every file of the packages (PACKAGES: their source and committed weights) where there is
    no git checkout. Cached results are keyed by it, and results files record it (``provenance``)."""
    commit = _git("rev-parse", "HEAD")
    diff = _git("diff", "--binary", "HEAD", text=False) if commit else None
    new = _git("ls-files", "--others", "--exclude-standard", "-z", "--", *PACKAGES, text=False) if commit else None
    if commit and diff is not None and new is not None:
        changes = files_digest(ROOT / name for name in sorted(new.decode().split("\0")) if name)
        return f"git:{commit}" + (f"+{hashlib.sha256(diff + changes.encode()).hexdigest()[:16]}"
                                  if diff or new else "")
    return "source:" + files_digest(path for package in PACKAGES for path in sorted((ROOT / package).rglob("*"))
                                    if path.is_file() and "__pycache__" not in path.parts)


def files_digest(paths) -> str:
    """A digest of the files ``paths`` (their names relative to ROOT and their bytes), 16 hex digits."""
    digest = hashlib.sha256()
    for path in paths:
        digest.update(path.relative_to(ROOT).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()[:16]


def provenance(code: str | None = None) -> dict:
    """{"package_version", "code_version" (``code``, else ``code_version()``), "git_commit", "git_dirty" (None when
    not a git checkout), "versions" (python, drake, torch, numpy; None when one is not installed), "cores",
    "date" (UTC, ISO 8601), "platform"}. A run that keys its cached results by ``code_version()`` passes the
    version it keyed them by, so its results file names the code its results came from."""
    code = code_version() if code is None else code
    commit = code.partition(":")[2].partition("+")[0] if code.startswith("git:") else None
    return {"package_version": _version("drakeslip"),
            "code_version": code,
            "git_commit": commit,
            "git_dirty": None if commit is None else "+" in code,
            "versions": {"python": platform.python_version(),
                         **{key: _version(dist) for key, dist in LIBRARIES.items()}},
            "cores": os.cpu_count(),
            "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "platform": f"{platform.system()} {platform.release()} {platform.machine()}; {sys.implementation.name}"}


def display_path(path) -> str:
    """``path`` relative to the repository when inside it (the same on every machine), else as given."""
    path = Path(path)
    try:
        return path.resolve().relative_to(ROOT).as_posix()
    except ValueError:
        return str(path)


def weights_digests(paths) -> dict:
    """{file (repository-relative): SHA-256} of each existing file in ``paths``; a missing one maps to None."""
    return {display_path(p): sha256(p) if Path(p).is_file() else None for p in paths}
