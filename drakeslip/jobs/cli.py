"""What every script of the toolkit shares, knowing nothing of the physics: argument types that reject bad values
up front, the flags that mean the same everywhere, and the exit codes. The arguments that name physical things (a
hopper, a terrain, a noise profile, a number inside a physical bound) are ``drakeslip.cli_physics``'s.

Exit status: 0 success; 1 a run or check that failed (no plan, a counterexample, a failed hop), or a file that could
not be written or read once the work started (a full disk: ``OSError``); 2 a usage or input error, reported in one
line before any work starts; 3 a simulation that crashed or timed out (its integrator raised, its derivatives were
NaN, or a hop outlasted the simulator's limit), reported in one line naming what failed
(``drakeslip.cli_physics.reports_crashes``): no verdict on the plan or the hopper. Importing this module makes two
errors one line on stderr instead of a traceback, for the rest of the script: Ctrl-C (SIGINT) says what was saved
(``interrupted``), leaves no worker process behind and ends the process by SIGINT, as an interrupted program does,
so a shell reports status 130 (128 + SIGINT) and stops a script that runs it; an ``OSError`` (no space left on the
device, a file that cannot be written) names the file and the reason, says what was saved, and ends with status 1:
the command was right, the run could not finish, and the same command resumes it once the cause is fixed (every
result file is written atomically, so none is left half written). Every script imports this module before anything
else of the toolkit, so that holds from its first statement; ``import drakeslip`` loads nothing heavy. Heavy
libraries (numpy, torch, pydrake, matplotlib, ray) are not imported here, so a script's ``--help`` is fast. An
argument that names an output file which is an input of another argument (or another output) is refused in one
line (``drakeslip.jobs.file_args``).
"""
from __future__ import annotations

import argparse
import errno
import math
import shlex
import sys
from pathlib import Path

from drakeslip.jobs.executors import make_executor
from drakeslip.jobs.file_args import clash, input_file, output_file, output_folder  # noqa: F401
from drakeslip.jobs.files import printable
from drakeslip.jobs.runner import saved_so_far

OK, FAILED, USAGE, CRASHED = 0, 1, 2, 3


class Formatter(argparse.ArgumentDefaultsHelpFormatter, argparse.RawDescriptionHelpFormatter):
    """Help with the module doc as written and every default shown (none for a flag without one)."""

    def _get_help_string(self, action):
        if action.default is None or action.default is False or action.required:
            return action.help
        return super()._get_help_string(action)


class ArgumentParser(argparse.ArgumentParser):
    """An argparse parser whose errors are one line on stderr and exit status 2, with the text it echoes shortened
    and its control characters escaped (``printable``). A flag must be spelled out in full (``--seed`` is not taken
    for ``--seeds``). Parsing refuses an output file that is an input file of another argument, or another output
    (``file_args.clash``)."""

    def __init__(self, description: str | None = None, **kwargs):
        super().__init__(description=description, formatter_class=Formatter, allow_abbrev=False, **kwargs)

    def error(self, message: str):
        self.exit(USAGE, f"{printable(self.prog)}: error: {printable(message)}\n")

    def parse_args(self, args=None, namespace=None):
        parsed = super().parse_args(args, namespace)
        self.check_outputs(parsed)
        return parsed

    def check_outputs(self, args, extra_outputs=()) -> None:
        """Refuse (exit 2, one line) an output of ``args`` or of ``extra_outputs`` ((option, path) of the files the
        script writes into an output folder) that is an input file of another argument or another output."""
        usage = self.format_usage()
        option = lambda dest: f"--{dest.replace('_', '-')}" if f"--{dest.replace('_', '-')}" in usage else dest
        problem = clash({option(dest): value for dest, value in vars(args).items()}, extra_outputs)
        if problem:
            self.error(problem)


def report_errors() -> None:
    """Make Ctrl-C and an ``OSError`` end this script in one line on stderr instead of a traceback (see the module
    doc): what the job runner saved (``drakeslip.jobs.runner.saved_so_far``) and how to resume. Importing this
    module calls it; other exceptions keep the hook they had."""
    if getattr(sys.excepthook, "reports_errors", False):
        return
    previous = sys.excepthook

    def hook(kind, error, trace):
        if issubclass(kind, KeyboardInterrupt):
            saved = saved_so_far()
            what = f"{saved}; rerun the same command to resume" if saved else "no results were cached"
            line = f"interrupted: {what}"
        elif issubclass(kind, OSError):
            saved = saved_so_far()
            line = f"error: {os_error(error)}" + (f"; {saved}; rerun the same command to resume" if saved else "")
        else:
            return previous(kind, error, trace)
        sys.stderr.write(f"{printable(Path(sys.argv[0]).name)}: {printable(line)}\n")
        sys.stderr.flush()

    hook.reports_errors = True
    sys.excepthook = hook


def os_error(error: OSError) -> str:
    """'FILE: No space left on device (ENOSPC)', or the reason alone when the error names no file (standard output
    on a full device)."""
    code = f" ({errno.errorcode[error.errno]})" if error.errno in errno.errorcode else ""
    why = f"{error.strerror}{code}" if error.strerror else str(error)
    return why if error.filename is None else f"{error.filename}: {why}"


report_errors()


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


def names(text: str) -> list[str]:
    """An argument type: a non-empty comma-separated list of names."""
    items = [t.strip() for t in text.split(",") if t.strip()]
    if not items:
        raise argparse.ArgumentTypeError(f"must name at least one entry, got {text!r}")
    return items


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
        sys.stderr.write(f"{printable(Path(sys.argv[0]).name)}: error: --address is for --executor ray\n")
        raise SystemExit(USAGE)
    return make_executor(args.executor, args.jobs, args.address)


def announce(argv=None) -> None:
    """Print the command line that reproduces this run."""
    args = sys.argv[1:] if argv is None else list(argv)
    print("reproduce with: python3 " + " ".join(shlex.quote(a) for a in [sys.argv[0], *args]), flush=True)
