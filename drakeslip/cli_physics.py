"""The command line of the toolkit's physical inputs: the ``--hopper`` flag, terrains, noise profiles, numbers
inside a physical bound (``drakeslip.bounds``), and a simulation that crashed reported in one line.

``drakeslip.jobs.cli`` holds what every script shares and knows nothing of the physics (the parser, the exit
codes, the one-line error hooks, integers, numbers, files, the parallel flags); this module builds on it. Each
type reads its input up front with the reader of its file format (``hopper_file.hopper_argument``,
``terrain_file.terrain_argument``, ``noise.profile``), so a bad value is one line and exit status 2 before any
work. Like ``drakeslip.jobs.cli``, it loads nothing heavy when imported (not even numpy): each reader is imported
when a type first needs it, so a script's ``--help`` stays fast.
"""
from __future__ import annotations

import argparse
import functools
import sys
from dataclasses import dataclass
from pathlib import Path

from drakeslip.bounds import Bound
from drakeslip.jobs.cli import CRASHED, number


def reports_crashes(main):
    """A script's ``main(argv)``, with a simulation that crashed or timed out (``drakeslip.state.SimulationCrash``)
    reported as one line on stderr, ``SCRIPT: simulation stopped: WHAT``, and exit status CRASHED instead of a
    traceback."""
    @functools.wraps(main)
    def run(argv=None):
        from drakeslip.state import SimulationCrash   # here, not with this module: it loads numpy

        try:
            return main(argv)
        except SimulationCrash as crash:
            sys.stderr.write(f"{Path(sys.argv[0]).name}: simulation stopped: {crash}\n")
            return CRASHED
    return run


def physical(bound: Bound, positive: bool = False):
    """An argument type: a finite number inside a physical bound of ``drakeslip.bounds`` (above 0 if
    ``positive``)."""
    return number(0.0 if positive else bound.low, bound.high, strict_low=positive)


def noise_profile(text: str):
    """An argument type: a noise profile by name, or NAME*K (drakeslip.noise.profile)."""
    from drakeslip.noise import profile

    try:
        return profile(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def add_hopper_argument(ap: argparse.ArgumentParser, default: str = "the paper's") -> None:
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
    """A terrain read from a file (``terrain_or_family``): its path and its Terrain. Its path is an input file
    (``drakeslip.jobs.file_args``), so no output of the script is written over it."""

    path: Path
    terrain: object

    def input_files(self) -> tuple:
        return (self.path,)


def terrain_or_family(*families: str):
    """An argument type: one of ``families`` (returned as the name), or a terrain file (a height profile or
    heights per cell, ``drakeslip.terrain_file``; returned as a TerrainFile); a malformed file is one line naming
    its row."""
    def parse(text: str):
        from drakeslip.terrain_file import terrain_argument

        if text in families:
            return text
        from drakeslip.spatial.heightmap import MAP_SUFFIXES

        if Path(text).suffix.lower() in MAP_SUFFIXES:   # a height map: the scripts that take one say so first
            raise argparse.ArgumentTypeError(f"{text!r} is a height map file; this --terrain takes a terrain profile "
                                             f"(a map's case is planned from a map suite: make_suites.py)")
        if not Path(text).is_file():
            if not families:
                raise argparse.ArgumentTypeError(f"no such terrain file: {text!r}")
            raise argparse.ArgumentTypeError(f"{text!r} is neither a terrain family ({', '.join(families)}) nor a "
                                             f"terrain file")
        return TerrainFile(Path(text), terrain_argument(text))
    return parse
