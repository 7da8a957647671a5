"""The files a script's arguments name, by role: the ones it reads and the ones it writes, so that no output ever
lands on an input (``--out s.json`` given with ``--suite s.json``, a cache beside ``--out`` that is the suite, a
symbolic or hard link to a plan file). The argument types (``input_file``, ``output_file``, ``output_folder``)
return paths that know their role; any other argument value may take part by having ``input_files()`` (a hopper
read from a file or folder, a terrain file) or ``output_files()``. ``clash`` compares them all, as files: resolved
paths (``./``, ``..``, symbolic links), and ``os.path.samefile`` where both exist (hard links)."""
from __future__ import annotations

import argparse
import os
from pathlib import Path


class InputPath(type(Path())):
    """A file an argument names for reading (``input_file``)."""

    def input_files(self) -> tuple:
        return (self,)


class OutputPath(type(Path())):
    """A file an argument names for writing (``output_file``); ``beside`` are the suffixes of the files written next
    to it (a job's cache, OUT.cases.jsonl)."""

    beside: tuple = ()

    def output_files(self) -> tuple:
        return (self, *(Path(str(self) + suffix) for suffix in self.beside))


class OutputFolder(type(Path())):
    """A folder an argument names for writing into (``output_folder``); the files a script writes there are its
    own to name (``clash``'s ``extra_outputs``)."""


def input_file(text: str) -> InputPath:
    """An argument type: a file that exists."""
    path = InputPath(text)
    if not path.is_file():
        raise argparse.ArgumentTypeError(f"no such file: {text!r}")
    return path


def output_file(*extensions: str, beside: tuple = ()):
    """An argument type: a path a file can be written to, ending in one of ``extensions`` (any if none): not an
    existing folder, and not inside something that is a file. ``beside``: suffixes of the files the script also
    writes next to it (``OutputPath.beside``)."""
    def parse(text: str) -> OutputPath:
        path = OutputPath(text)
        path.beside = tuple(beside)
        if extensions and path.suffix.lower() not in extensions:
            raise argparse.ArgumentTypeError(f"must end in {' or '.join(extensions)}, got {text!r}")
        if path.is_dir():
            raise argparse.ArgumentTypeError(f"{text!r} is a folder; give a file name")
        check_writable_folder(text, path.parents, "write")
        return path
    return parse


def output_folder(text: str) -> OutputFolder:
    """An argument type: a folder that exists or can be made: not a file, not inside a file, writable."""
    path = OutputFolder(text)
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


def same_file(a: Path, b: Path) -> bool:
    """Whether two paths name one file: the same file on disk when both exist (hard links too), else the same
    resolved path."""
    try:
        if a.exists() and b.exists():
            return os.path.samefile(a, b)
        return a.resolve() == b.resolve()
    except (OSError, RuntimeError):   # a path that cannot be resolved (a symlink loop) names no file of the other
        return False


def files_by_role(values: dict) -> tuple[list, list]:
    """([(argument, input file)], [(argument, output file)]) of the argument values ``values`` (name -> value or
    list of values)."""
    inputs, outputs = [], []
    for name, value in values.items():
        for item in value if isinstance(value, (list, tuple)) else [value]:
            if hasattr(item, "input_files"):
                inputs += [(name, Path(path)) for path in item.input_files()]
            if hasattr(item, "output_files"):
                outputs += [(name, Path(path)) for path in item.output_files()]
    return inputs, outputs


def clash(values: dict, extra_outputs=()) -> str | None:
    """The first output among ``values`` (argument name -> value, as ``vars(args)`` holds them) and
    ``extra_outputs`` ((argument name, path) of files a script writes into an output folder) that is an input of
    another argument, or the same file as another output, as one line; None when there is none."""
    inputs, outputs = files_by_role(values)
    outputs += [(name, Path(path)) for name, path in extra_outputs]
    for k, (name, out) in enumerate(outputs):
        for source, path in inputs:
            if same_file(out, path):
                return (f"{name} would write {str(out)!r}, which is the {source} file {str(path)!r}: an input is "
                        f"never overwritten; give another {name}")
        for other, path in outputs[:k]:
            if same_file(out, path):
                return f"{other} and {name} would both write {str(out)!r}; give them different files"
    return None
