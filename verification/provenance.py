"""Where a result came from: the code, the libraries, the machine and the date, recorded in every results JSON.

``provenance()`` is cheap (well under a second): library versions are read from the installed packages'
metadata (``importlib.metadata``), never by importing torch or pydrake, and git is asked with a timeout.
``weights_digests`` gives the SHA-256 of each weights file a planner read, so a retrained model shows in the
results of any run that used it.
"""
from __future__ import annotations

import datetime
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


def _version(distribution: str) -> str | None:
    try:
        return metadata.version(distribution)
    except metadata.PackageNotFoundError:
        return None


def _git(*args: str) -> str | None:
    """The output of ``git args`` in ROOT, None when git is missing, ROOT is no repository, or it hangs."""
    try:
        run = subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, timeout=GIT_TIMEOUT_S)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return run.stdout.strip() if run.returncode == 0 else None


def provenance() -> dict:
    """{"package_version", "git_commit", "git_dirty" (None when not a git checkout), "versions" (python, drake,
    torch, numpy; None when one is not installed), "cores", "date" (UTC, ISO 8601), "platform"}."""
    commit = _git("rev-parse", "HEAD")
    # tracked files only: untracked outputs (out/, caches) do not make the code differ from the commit
    status = _git("status", "--porcelain", "--untracked-files=no") if commit else None
    return {"package_version": _version("drakeslip"),
            "git_commit": commit,
            "git_dirty": None if status is None else bool(status),
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
