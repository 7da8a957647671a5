"""What every script of the toolkit shares: argument types that reject bad values up front, the flags that mean
the same everywhere, and the exit codes.

Exit status: 0 success; 1 a run or check that failed (no plan, a counterexample, a failed hop); 2 a usage or input
error, reported in one line before any work starts; 3 a simulation that crashed or timed out (its integrator raised, its
derivatives were NaN, or a hop outlasted the simulator's limit: ``drakeslip.state.SimulationCrash``), reported in one
line naming what failed (``reports_crashes``): no verdict on the plan or the hopper. Ctrl-C (SIGINT) ends a script with
one line on stderr saying what it saved (``interrupted``) and no worker process left behind; the process then ends by
SIGINT, as an interrupted program does, so a shell reports status 130 (128 + SIGINT) and stops a script that runs it.
Heavy libraries (torch, pydrake, matplotlib, ray) are not imported here, so a script's ``--help`` is fast.
"""
from __future__ import annotations

import argparse
import functools
import math
import os
import shlex
import sys
from dataclasses import dataclass
from pathlib import Path

from drakeslip.bounds import Bound
from drakeslip.state import SimulationCrash
from drakeslip.jobs.executors import make_executor
from drakeslip.jobs.runner import saved_so_far

OK, FAILED, USAGE, CRASHED = 0, 1, 2, 3


class Formatter(argparse.ArgumentDefaultsHelpFormatter, argparse.RawDescriptionHelpFormatter):
    """Help with the module doc as written and every default shown (none for a flag without one)."""

    def _get_help_string(self, action):
        if action.default is None or action.default is False or action.required:
            return action.help
        return super()._get_help_string(action)


class ArgumentParser(argparse.ArgumentParser):
    """An argparse parser whose errors are one line on stderr and exit status 2. A flag must be spelled out in
    full (``--seed`` is not taken for ``--seeds``)."""

    def __init__(self, description: str | None = None, **kwargs):
        super().__init__(description=description, formatter_class=Formatter, allow_abbrev=False, **kwargs)
        report_interrupts()

    def error(self, message: str):
        self.exit(USAGE, f"{self.prog}: error: {message}\n")


def reports_crashes(main):
    """A script's ``main(argv)``, with a simulation that crashed or timed out (``SimulationCrash``) reported as one
    line on stderr, ``SCRIPT: simulation stopped: WHAT``, and exit status CRASHED instead of a traceback."""
    @functools.wraps(main)
    def run(argv=None):
        try:
            return main(argv)
        except SimulationCrash as crash:
            sys.stderr.write(f"{Path(sys.argv[0]).name}: simulation stopped: {crash}\n")
            return CRASHED
    return run


def report_interrupts() -> None:
    """Make Ctrl-C end this script in one line on stderr instead of a traceback: what the job runner saved
    (``drakeslip.jobs.runner.saved_so_far``) and how to resume, or that nothing was cached. Every script's parser
    calls it; other exceptions keep the hook they had."""
    if getattr(sys.excepthook, "reports_interrupts", False):
        return
    previous = sys.excepthook

    def hook(kind, error, trace):
        if not issubclass(kind, KeyboardInterrupt):
            return previous(kind, error, trace)
        saved = saved_so_far()
        what = f"{saved}; rerun the same command to resume" if saved else "no results were cached"
        sys.stderr.write(f"{Path(sys.argv[0]).name}: interrupted: {what}\n")
        sys.stderr.flush()

    hook.reports_interrupts = True
    sys.excepthook = hook


def integer(low: int | None = None, high: int | None = None):
    """An argument type: an integer in [low, high]."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None
        if (low is not None and value < low) or (high is not None and value > high):
            raise argparse.ArgumentTypeError(f"must be an integer in [{low if low is not None else '-inf'}, "
                                             f"{high if high is not None else 'inf'}], got {text!r}")
        return value
    return parse


def number(low: float | None = None, high: float | None = None, strict_low: bool = False):
    """An argument type: a finite number in [low, high] (above ``low`` if ``strict_low``); NaN and infinities are
    refused."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None
        too_low = low is not None and (value <= low if strict_low else value < low)
        if not math.isfinite(value) or too_low or (high is not None and value > high):
            where = f"{'>' if strict_low else '>='} {low}" if low is not None else ""
            where += (" and " if where and high is not None else "") + (f"<= {high}" if high is not None else "")
            raise argparse.ArgumentTypeError(f"must be a finite number{' ' + where if where else ''}, got {text!r}")
        return value
    return parse


def physical(bound: Bound, positive: bool = False):
    """An argument type: a finite number inside a physical bound of ``drakeslip.bounds`` (above 0 if
    ``positive``)."""
    return number(0.0 if positive else bound.low, bound.high, strict_low=positive)


positive_int = integer(1)
non_negative_int = integer(0)
positive = number(0.0, strict_low=True)
non_negative = number(0.0)
finite = number()
probability = number(0.0, 1.0)


def numbers(count: int | None, each=finite):
    """An argument type: ``count`` (None: one or more) comma-separated numbers, each checked by ``each``."""
    def parse(text: str) -> tuple:
        parts = text.split(",")
        if count is not None and len(parts) != count:
            raise argparse.ArgumentTypeError(f"must be {count} comma-separated numbers, got {text!r}")
        return tuple(each(p) for p in parts)
    return parse


def noise_profile(text: str):
    """An argument type: a noise profile by name, or NAME*K (drakeslip.noise.profile)."""
    from drakeslip.noise import profile

    try:
        return profile(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def names(text: str) -> list[str]:
    """An argument type: a non-empty comma-separated list of names."""
    items = [t.strip() for t in text.split(",") if t.strip()]
    if not items:
        raise argparse.ArgumentTypeError(f"must name at least one entry, got {text!r}")
    return items


def input_file(text: str) -> Path:
    """An argument type: a file that exists."""
    path = Path(text)
    if not path.is_file():
        raise argparse.ArgumentTypeError(f"no such file: {text!r}")
    return path


def output_file(*extensions: str):
    """An argument type: a path a file can be written to, ending in one of ``extensions`` (any if none): not an
    existing folder, and not inside something that is a file."""
    def parse(text: str) -> Path:
        path = Path(text)
        if extensions and path.suffix.lower() not in extensions:
            raise argparse.ArgumentTypeError(f"must end in {' or '.join(extensions)}, got {text!r}")
        if path.is_dir():
            raise argparse.ArgumentTypeError(f"{text!r} is a folder; give a file name")
        check_writable_folder(text, path.parents, "write")
        return path
    return parse


def output_folder(text: str) -> Path:
    """An argument type: a folder that exists or can be made: not a file, not inside a file, writable."""
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(f"{text!r} is a file, not a folder")
    check_writable_folder(text, (path, *path.parents), "make")
    return path


def check_writable_folder(text: str, folders, verb: str) -> None:
    """The first of ``folders`` (a path's parents, nearest first) that exists is a folder this process can write
    in (and enter); else ArgumentTypeError "cannot VERB TEXT: ..."."""
    for folder in folders:
        if folder.exists():
            if not folder.is_dir():
                raise argparse.ArgumentTypeError(f"cannot {verb} {text!r}: {str(folder)!r} is a file")
            if not os.access(folder, os.W_OK | os.X_OK):
                raise argparse.ArgumentTypeError(f"cannot {verb} {text!r}: {str(folder)!r} is not writable")
            return


def add_hopper(ap: argparse.ArgumentParser, default: str = "the paper's") -> None:
    """``--hopper``: a hopper file, a hopper folder or a packaged hopper's name, read up front
    (``drakeslip.hopper_file.hopper_argument``: a bad one is one line, exit status 2); None when not given."""
    from drakeslip.hopper_file import hopper_argument, packaged_hoppers

    ap.add_argument("--hopper", type=hopper_argument, default=None,
                    help="the hopper: a hopper file (JSON or TOML: mass, leg_length, stiffness, ...; "
                         "drakeslip/hopper_file.py), a hopper folder (examples/train_hopper.py: the file and the "
                         f"weights trained for it), or a packaged hopper ({', '.join(packaged_hoppers())}) "
                         f"(default: {default})")


@dataclass(frozen=True)
class TerrainFile:
    """A terrain read from a file (``terrain_or_family``): its path and its Terrain."""

    path: Path
    terrain: object


def terrain_or_family(*families: str):
    """An argument type: one of ``families`` (returned as the name), or a terrain file (a height profile or
    heights per cell, ``drakeslip.terrain_file``; returned as a TerrainFile); a malformed file is one line naming
    its row."""
    def parse(text: str):
        from drakeslip.terrain_file import terrain_argument

        if text in families:
            return text
        if not Path(text).is_file():
            if not families:
                raise argparse.ArgumentTypeError(f"no such terrain file: {text!r}")
            raise argparse.ArgumentTypeError(f"{text!r} is neither a terrain family ({', '.join(families)}) nor a "
                                             f"terrain file")
        return TerrainFile(Path(text), terrain_argument(text))
    return parse


def add_parallel(ap: argparse.ArgumentParser, jobs: int = 1) -> None:
    """``--jobs``, ``--executor`` and ``--address``: where the independent tasks of a job run."""
    ap.add_argument("--jobs", type=positive_int, default=jobs,
                    help="tasks at a time: local worker processes (1: this process), or tasks in flight on Ray")
    ap.add_argument("--executor", choices=("local", "ray"), default="local",
                    help="local processes on this machine, or a Ray cluster (results come back to this process)")
    ap.add_argument("--address", default=None,
                    help="the Ray cluster's address (e.g. auto or ray://host:10001; default: a local Ray instance)")


def executor(args):
    """The executor ``add_parallel``'s flags ask for."""
    if args.executor == "local" and args.address is not None:
        sys.stderr.write(f"{Path(sys.argv[0]).name}: error: --address is for --executor ray\n")
        raise SystemExit(USAGE)
    return make_executor(args.executor, args.jobs, args.address)


def announce(argv=None) -> None:
    """Print the command line that reproduces this run."""
    args = sys.argv[1:] if argv is None else list(argv)
    print("reproduce with: python3 " + " ".join(shlex.quote(a) for a in [sys.argv[0], *args]), flush=True)
