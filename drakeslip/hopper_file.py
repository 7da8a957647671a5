"""Hopper files: a SLIP hopper's parameters in a small JSON or TOML file, and hopper folders that hold one with the
weights files trained for it.

A hopper file (JSON; TOML with the same keys is read too, by its ``.toml`` suffix)::

    {"format": "drakeslip-hopper/1", "name": "paper", "mass": 7.0, "leg_length": 0.5, "stiffness": 3200.0,
     "gravity": 9.81, "friction": 0.8, "min_leg_length": 0.3}

mass [kg], leg_length (spring rest length L0) [m] and stiffness [N/m] are required; gravity [m/s^2] (9.81),
friction (0.8) and min_leg_length [m] (where the spring bottoms out, 0.6 leg_length) default to ``SlipParams``'s.
The stroke may be given instead of min_leg_length as ``stroke``, the fraction of the leg the spring can compress
(min_leg_length = leg_length (1 - stroke)); giving both is an error. ``name`` (default: the file's stem) and
``format`` are optional. Saved files spell every field out, with min_leg_length, so they load to the same floats.

A hopper folder holds ``hopper.json``, the weights files trained for that hopper, and a ``SHA256SUMS`` manifest
(``drakeslip.jobs.files``) listing every one of them; ``load_hopper`` takes the folder or the file. The manifest is
what the folder holds: a planner whose weights it does not list reads the committed ones, as it does for a lone
hopper file (a folder just made, before training, lists only ``hopper.json``); a folder without a manifest, a file
the manifest lists that is missing, or a weights file (``*.pt``) that it does not list (a copy cut short, a file
dropped in by hand) is refused in one line naming the folder and the file, rather than silently planning with the
committed weights or an unchecked file. The paper's hopper ships as
``drakeslip/hoppers/paper.json`` and is the default everywhere (``paper_hopper()``, ``--hopper paper``).
"""
from __future__ import annotations

import argparse
import functools
import json
import tomllib
from dataclasses import asdict, dataclass
from pathlib import Path

from drakeslip.jobs.files import (MANIFEST, atomic_write, first_line, known_fields, manifest_entries, read_json,
                                  record_digest, sha256)
from drakeslip.apex_correction import ApexCorrection
from drakeslip.params import RobotTemplate, SlipParams, check_name, check_number
from drakeslip.units import HopperUnits

HOPPER_FORMAT = "drakeslip-hopper/1"
FOLDER_FILE = "hopper.json"            # the hopper file inside a hopper folder
PACKAGED = Path(__file__).resolve().parent / "hoppers"
PARAM_FIELDS = ("mass", "leg_length", "stiffness", "gravity", "friction", "min_leg_length")  # SlipParams's order
REQUIRED = ("mass", "leg_length", "stiffness")
# What makes the hopper: every parameter but the friction, which runs take from the ground (a suite's, a plan's).
BODY_FIELDS = ("mass", "leg_length", "stiffness", "gravity", "min_leg_length")
FIELDS = ("format", "name", *PARAM_FIELDS, "stroke", "correction")


@dataclass(frozen=True)
class NamedHopper:
    """A hopper as the toolkit names it, what a hopper file holds: its ``params``, its ``name``, and where it was
    read from: ``sha256`` of the hopper file's bytes, ``source`` (the file) and ``folder`` (the hopper folder, None
    for a lone file). A hopper built in code or read back from a record has no source. (The Drake system that
    simulates one is ``drakeslip.slip_hopper.SlipHopper``; the robot's model, ``drakeslip/multibody/robot.sdf``.)"""

    params: SlipParams
    name: str
    sha256: str | None = None
    source: Path | None = None
    folder: Path | None = None

    @property
    def units(self) -> HopperUnits:
        return HopperUnits.of(self.params)

    def weights(self, name: str) -> Path | None:
        """The path of the weights file ``name`` in this hopper's folder, or None when there is no folder or no
        such file in it. (``drakeslip.jobs.files.load_weights`` checks it against the folder's manifest.)"""
        if not isinstance(name, str) or not name or Path(name).name != name:
            raise ValueError(f"a weights file name must be a plain file name, got {name!r}")
        if self.folder is None:
            return None
        path = self.folder / name
        return path if path.is_file() else None

    def input_files(self) -> tuple:
        """The files this hopper was read from: its hopper file, and for a folder its manifest and every file the
        manifest lists (so that no script writes its output over one, ``drakeslip.jobs.file_args``)."""
        if self.folder is None:
            return () if self.source is None else (self.source,)
        return (self.source, self.folder / MANIFEST, *(self.folder / name for name in manifest_entries(self.folder)))

    def to_record(self) -> dict:
        """What results JSON and plan files keep of the hopper: its name, every parameter, and the file's digest."""
        return {"name": self.name, "params": asdict(self.params), "sha256": self.sha256}


def params_from_fields(d: dict, source: str) -> SlipParams:
    """SlipParams from a hopper document's parameter fields (see the module doc); a missing, malformed or
    out-of-bounds one raises ValueError naming ``source`` and the field."""
    for key in REQUIRED:
        if key not in d:
            raise ValueError(f"{source} is missing the field {key!r}")
    values = {key: check_number(d[key], f"{source}: {key}", positive=True)
              for key in (*PARAM_FIELDS, "stroke") if key in d}
    if "stroke" in values:
        if "min_leg_length" in values:
            raise ValueError(f"{source}: give stroke or min_leg_length, not both")
        stroke = values.pop("stroke")
        if not stroke < 1.0:
            raise ValueError(f"{source}: stroke must be a fraction of the leg in (0, 1), got {stroke!r}")
        values["min_leg_length"] = values["leg_length"] * (1.0 - stroke)
    try:
        return SlipParams(**values)
    except ValueError as error:
        raise ValueError(f"{source}: {error}") from None


def hopper_from_dict(d, source: str, default_name: str, folder: Path | None = None) -> tuple[SlipParams, str]:
    """(params, name) from a hopper document; any bad field raises ValueError naming ``source`` and the field. A
    "correction" ({"file": a correction weights file beside the hopper file, in ``folder``, "sha256": its digest})
    makes the params a ``RobotTemplate``."""
    if not isinstance(d, dict):
        raise ValueError(f"{source} must hold a table of fields, got {type(d).__name__}")
    known_fields(d, FIELDS, source)
    if "format" in d and d["format"] != HOPPER_FORMAT:
        raise ValueError(f"{source}: format must be {HOPPER_FORMAT!r}, got {d['format']!r}")
    name = check_name(d.get("name", default_name), f"{source}: name")
    params = params_from_fields({k: v for k, v in d.items() if k not in ("format", "name", "correction")}, source)
    if "correction" in d:
        params = RobotTemplate(**asdict(params), correction=named_correction(d["correction"], source, folder))
    return params, name


def named_correction(entry, source: str, folder: Path | None) -> ApexCorrection:
    """The correction a hopper document's "correction" entry names, its file read and checked against its digest."""
    if not (isinstance(entry, dict) and set(entry) == {"file", "sha256"} and isinstance(entry["file"], str)
            and isinstance(entry["sha256"], str) and Path(entry["file"]).name == entry["file"] and folder is not None):
        raise ValueError(f'{source}: correction must be {{"file": a file name beside the hopper file, "sha256": its '
                         f'digest}}, got {entry!r}')
    try:
        return ApexCorrection(entry["sha256"], str(folder / entry["file"]))
    except ValueError as error:
        raise ValueError(f"{source}: {error}") from None


def load_hopper(path) -> NamedHopper:
    """The hopper in ``path``: a hopper file (``.toml`` read as TOML, anything else as JSON) or a hopper folder.
    A missing path raises FileNotFoundError; a malformed file, or a folder's hopper file that does not match its
    manifest, raises ValueError naming the file (and the field)."""
    path = Path(path)
    folder = None
    if path.is_dir():
        folder, path = path, path / FOLDER_FILE
        if not path.is_file():
            raise ValueError(f"hopper folder {folder} has no {FOLDER_FILE}")
        check_folder_files(folder)
    elif not path.is_file():
        raise FileNotFoundError(f"no such hopper file or folder: {path}")
    source = f"hopper file {path}"
    if path.suffix.lower() == ".toml":
        try:
            document = tomllib.loads(path.read_text())
        except UnicodeDecodeError as error:
            raise ValueError(f"{source} is not TOML: not UTF-8 text ({error.reason} at byte {error.start})") from None
        except tomllib.TOMLDecodeError as error:
            raise ValueError(f"{source} is not valid TOML: {error}") from None
    else:
        document = read_json(path, "hopper file")
    digest = sha256(path)
    if folder is not None:
        expected = manifest_entries(folder).get(path.name)
        if expected is not None and expected != digest:
            raise ValueError(f"{source} does not match its SHA-256 in {folder / MANIFEST} (expected "
                             f"{expected[:16]}..., got {digest[:16]}...): it was changed after the folder was written")
    params, name = hopper_from_dict(document, source, path.stem if folder is None else folder.name, path.parent)
    return NamedHopper(params, name, digest, path, folder)


def check_folder_files(folder: Path) -> None:
    """ValueError in one line unless ``folder``'s manifest exists, every file it lists is there, and it lists every
    weights file (``*.pt``) there (see the module doc)."""
    if not (folder / MANIFEST).is_file():
        raise ValueError(f"hopper folder {folder} has no {MANIFEST} manifest, so which weights it should hold cannot "
                         f"be told: give its {FOLDER_FILE} instead, or make the folder with examples/train_hopper.py")
    listed = manifest_entries(folder)
    missing = sorted(name for name in listed if not (folder / name).is_file())
    if missing:
        raise ValueError(f"hopper folder {folder}: {missing[0]}, listed in its {MANIFEST}, is missing (rerun "
                         f"examples/train_hopper.py to write it, or give the folder's {FOLDER_FILE} instead)")
    unlisted = sorted(path.name for path in folder.glob("*.pt") if path.name not in listed)
    if unlisted:
        raise ValueError(f"hopper folder {folder}: {unlisted[0]} is not listed in its {MANIFEST}, so it cannot be "
                         f"checked (rerun examples/train_hopper.py to finish the folder, or remove the file)")


def hopper_document(hopper: NamedHopper) -> dict:
    """The JSON document ``save_hopper`` writes: the format, the name and every parameter (a correction named by its
    file's name: it must lie beside the hopper file)."""
    fields = {name: getattr(hopper.params, name) for name in PARAM_FIELDS}
    correction = getattr(hopper.params, "correction", None)
    if correction is not None:
        fields["correction"] = {"file": Path(correction.path).name, "sha256": correction.sha256}
    return {"format": HOPPER_FORMAT, "name": hopper.name, **fields}


def save_hopper(hopper: NamedHopper, path) -> NamedHopper:
    """Write ``hopper`` as a JSON hopper file, atomically, and return it as read back from ``path``. ``path`` is a
    file name ending in .json, or an existing folder, which gets ``hopper.json`` (and its manifest entry, when it
    has a manifest; without one it is no hopper folder, and the file comes back as a lone hopper file)."""
    path = Path(path)
    if path.is_dir():
        file = path / FOLDER_FILE
    elif path.suffix.lower() == ".json":
        file = path
    else:
        raise ValueError(f"save_hopper writes JSON: give a file name ending in .json or a folder, got {str(path)!r}")
    with atomic_write(file, "w") as f:
        json.dump(hopper_document(hopper), f, indent=2)
        f.write("\n")
    record_digest(file)
    return load_hopper(path if path.is_file() or (path / MANIFEST).is_file() else file)


def make_hopper_folder(hopper: NamedHopper, folder) -> NamedHopper:
    """Make ``folder`` a hopper folder for ``hopper``: ``hopper.json`` and a manifest listing it (other entries of
    an existing manifest are kept). Trainers then write weights files into it and call
    ``drakeslip.jobs.files.record_digest`` on each. Returns the hopper as loaded from the folder."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise ValueError(f"cannot make hopper folder {folder}: it is a file")
    folder.mkdir(parents=True, exist_ok=True)
    manifest = folder / MANIFEST
    if not manifest.is_file():
        with atomic_write(manifest, "w"):
            pass
    return save_hopper(hopper, folder)


def hopper_from_record(record, where: str) -> NamedHopper:
    """The hopper a results or plan file's record (``NamedHopper.to_record``) describes; a bad record raises ValueError
    naming ``where`` and the field."""
    if not isinstance(record, dict):
        raise ValueError(f"{where} must be an object, got {type(record).__name__}")
    for key in ("name", "params"):
        if key not in record:
            raise ValueError(f"{where} is missing the field {key!r}")
    name, params, digest = record["name"], record["params"], record.get("sha256")
    check_name(name, f"{where}.name")
    if digest is not None and not isinstance(digest, str):
        raise ValueError(f"{where}.sha256 must be a string or null, got {digest!r}")
    if not isinstance(params, dict):
        raise ValueError(f"{where}.params must be an object, got {type(params).__name__}")
    known_fields(params, PARAM_FIELDS, f"{where}.params")
    return NamedHopper(params_from_fields(params, f"{where}.params"), name, digest)


def describe_params(params: SlipParams) -> str:
    """'7 kg, L0 0.5 m, 3200 N/m, stroke 0.4' (and g when it is not the Earth's)."""
    stroke = 1.0 - params.min_leg_length / params.leg_length
    gravity = "" if params.gravity == 9.81 else f", g {params.gravity:.4g} m/s^2"
    return (f"{params.mass:.4g} kg, L0 {params.leg_length:.4g} m, {params.stiffness:.5g} N/m, "
            f"stroke {stroke:.3g}{gravity}")


def check_same_hopper(hopper: NamedHopper, params: SlipParams, what: str) -> None:
    """ValueError in one line when ``params`` (what ``what``, e.g. "plan file out/plan.json", was made for) is
    another hopper than ``hopper``: a body field (BODY_FIELDS) differs. The friction is the ground's and may."""
    other = [key for key in BODY_FIELDS if getattr(params, key) != getattr(hopper.params, key)]
    if other:
        key = other[0]
        raise ValueError(f"{what} is for another hopper ({describe_params(params)}) than {hopper.name!r} "
                         f"({describe_params(hopper.params)}): {key} {getattr(params, key)!r} != "
                         f"{getattr(hopper.params, key)!r}")


def hopper_for(params: SlipParams) -> NamedHopper:
    """The hopper to record for ``params``: the paper's when its body is the paper's, else one named 'custom'."""
    paper = paper_hopper()
    if all(getattr(params, key) == getattr(paper.params, key) for key in BODY_FIELDS):
        return paper
    return NamedHopper(params, "custom")


def packaged_hoppers() -> list[str]:
    """Names of the hopper files that ship with drakeslip (``--hopper NAME``)."""
    return sorted(p.stem for p in PACKAGED.glob("*.json"))


@functools.lru_cache(maxsize=None)
def paper_hopper() -> NamedHopper:
    """The paper's hopper (``SlipParams()``), from the packaged hopper file: the default everywhere."""
    return load_hopper(PACKAGED / "paper.json")


def hopper_argument(text: str) -> NamedHopper:
    """An argument type: a hopper file or folder, or the name of a packaged hopper (``paper``); a bad one is one
    line (argparse.ArgumentTypeError)."""
    path = Path(text)
    if not path.exists() and text in packaged_hoppers():
        path = PACKAGED / f"{text}.json"
    try:
        return load_hopper(path)
    except FileNotFoundError:
        raise argparse.ArgumentTypeError(f"no such hopper file or folder: {text!r} (packaged hoppers: "
                                         f"{', '.join(packaged_hoppers())})") from None
    except (ValueError, OSError) as error:
        raise argparse.ArgumentTypeError(first_line(error)) from None
