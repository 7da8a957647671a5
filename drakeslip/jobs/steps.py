"""Pipelines of example scripts: each step a command of its own (examples/NAME.py ARGS), printed before it runs and
timed after, so the same commands run by hand give the same files (examples/train_expert.py, train_hopper.py). The
scripts are found in the folder of the script that runs the pipeline, which an installed package does not hold."""
from __future__ import annotations

import os
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path


def shown(command: list[str]) -> str:
    """The shell line of a step ``[script, *args]``: ``python3 examples/SCRIPT ARGS``."""
    return "python3 " + " ".join(shlex.quote(a) for a in [f"examples/{command[0]}", *command[1:]])


def run_step(command: list[str], scripts: Path) -> int:
    """Run COMMAND (a script in the folder ``scripts`` and its arguments) in a process of its own, printing it first
    and its time after; its exit status. On Ctrl-C the step ends as its script does, saying in one line what it
    saved, and so does this process."""
    print("$ " + shown(command), flush=True)
    t0 = time.perf_counter()
    step = subprocess.Popen([sys.executable, str(Path(scripts) / command[0]), *command[1:]])
    try:
        code = step.wait()
    except KeyboardInterrupt:
        step.send_signal(signal.SIGINT)  # a Ctrl-C reached it too; a SIGINT sent to this process alone is passed on
        step.wait()
        end_by_sigint()
    print(f"  ({time.perf_counter() - t0:.0f} s, exit status {code})", flush=True)
    return code


def end_by_sigint() -> None:
    """End as an interrupted program does (status 130 in a shell), with no line of this process's own."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    os.kill(os.getpid(), signal.SIGINT)
