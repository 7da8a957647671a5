"""Hopper files and folders: the paper's hopper is the packaged default with unit factors of exactly 1, another
hopper loads with the right units, files round-trip, and every bad file is refused in one line naming the file
and the field."""
import argparse
import json
import math

import pytest

from drakeslip import SlipParams
from drakeslip.hopper_file import (FOLDER_FILE, PACKAGED, NamedHopper, hopper_argument, hopper_from_record, load_hopper,
                                   make_hopper_folder, paper_hopper, save_hopper)
from drakeslip.jobs.cli import USAGE, ArgumentParser
from drakeslip.jobs.files import MANIFEST, manifest_entries, record_digest, sha256
from drakeslip.units import HopperUnits, dimensionless_stiffness

BIG = {"name": "big", "mass": 12, "leg_length": 0.7, "stiffness": 6000}


def write(path, document):
    path.write_text(json.dumps(document))
    return path


def test_the_paper_hoppers_factors_are_exactly_one():
    units = HopperUnits.of(SlipParams())
    assert (units.length, units.speed, units.time, units.mass) == (1.0, 1.0, 1.0, 1.0)
    assert units.stiffness == pytest.approx(3200 * 0.5 / (7 * 9.81)) and 23.2 < units.stiffness < 23.4
    assert 0.8 * units.speed == 0.8 and -1.0 * units.length == -1.0


def test_the_packaged_paper_hopper_is_slip_params_defaults():
    hopper = paper_hopper()
    assert hopper.params == SlipParams() and hopper.name == "paper"
    assert hopper.sha256 == sha256(PACKAGED / "paper.json")
    assert hopper_argument("paper") == hopper


def test_a_12kg_hopper_file_loads_with_its_units(tmp_path):
    hopper = load_hopper(write(tmp_path / "big.json", BIG))
    assert hopper.params == SlipParams(mass=12.0, leg_length=0.7, stiffness=6000.0)
    assert hopper.params.gravity == 9.81 and hopper.params.friction == 0.8
    assert hopper.params.min_leg_length == pytest.approx(0.42)
    units = hopper.units
    assert units.length == pytest.approx(1.4)
    assert units.speed == pytest.approx(math.sqrt(9.81 * 0.7 / (9.81 * 0.5)))
    assert units.time == pytest.approx(math.sqrt(0.7 / 0.5))
    assert units.mass == pytest.approx(12 / 7)
    assert units.stiffness == pytest.approx(6000 * 0.7 / (12 * 9.81)) == dimensionless_stiffness(hopper.params)


def test_toml_with_a_stroke_reads_as_json_with_min_leg_length(tmp_path):
    toml = tmp_path / "big.toml"
    toml.write_text('name = "big"\nmass = 12\nleg_length = 0.7\nstiffness = 6000\nstroke = 0.25\n')
    as_json = load_hopper(write(tmp_path / "big.json", {**BIG, "min_leg_length": 0.7 * 0.75}))
    assert load_hopper(toml).params == as_json.params


def test_save_and_load_round_trip_to_the_bit(tmp_path):
    hopper = NamedHopper(SlipParams(mass=3.3, leg_length=0.31, stiffness=1234.5, gravity=9.7, friction=0.65,
                               min_leg_length=0.2), "small")
    saved = save_hopper(hopper, tmp_path / "small.json")
    assert saved.params == hopper.params and saved.name == "small"
    assert saved.sha256 == sha256(tmp_path / "small.json") and saved.source == tmp_path / "small.json"
    # the packaged file is exactly what save_hopper writes
    save_hopper(paper_hopper(), tmp_path / "paper.json")
    assert (tmp_path / "paper.json").read_bytes() == (PACKAGED / "paper.json").read_bytes()


@pytest.mark.parametrize("document, field", [
    ({**BIG, "masss": 1}, "unknown field 'masss'"),
    ({"mass": 12, "leg_length": 0.7}, "missing the field 'stiffness'"),
    ({**BIG, "mass": -12}, "mass must be a positive finite number"),
    ({**BIG, "stiffness": "6000"}, "stiffness must be a positive finite number"),
    ({**BIG, "friction": True}, "friction must be a positive finite number"),
    ({**BIG, "gravity": float("nan")}, "gravity must be a positive finite number"),
    ({**BIG, "stroke": 0.4, "min_leg_length": 0.4}, "give stroke or min_leg_length, not both"),
    ({**BIG, "stroke": 1.0}, "stroke must be a fraction of the leg in \\(0, 1\\)"),
    ({**BIG, "min_leg_length": 0.7}, "min_leg_length must lie in \\(0, leg_length=0.7\\)"),
    ({**BIG, "name": ""}, "name must be a string of 1 to 100 printable characters"),
    ({**BIG, "name": "a\x1b[2Jb"}, r"printable characters, no / or \\, got .a\\x1b\[2Jb."),   # escaped, not sent
    ({**BIG, "name": "x" * 101}, r"got .xxxxxxxxxxxxxxx\.\.\. \(101 characters\)"),
    ({**BIG, "format": "drakeslip-hopper/9"}, "format must be 'drakeslip-hopper/1'"),
    ([12, 0.7, 6000], "must hold a table of fields"),
])
def test_a_bad_hopper_file_is_one_error_naming_the_file_and_field(tmp_path, document, field):
    path = write(tmp_path / "bad.json", document)
    with pytest.raises(ValueError, match=field) as error:
        load_hopper(path)
    assert str(path) in str(error.value) and "\n" not in str(error.value)


@pytest.mark.parametrize("name, text, what", [
    ("bad.json", '{"mass": 12,', "not valid JSON"),
    ("bad.toml", "mass = = 12", "not valid TOML"),
])
def test_a_file_that_does_not_parse_names_itself(tmp_path, name, text, what):
    (tmp_path / name).write_text(text)
    with pytest.raises(ValueError, match=what) as error:
        load_hopper(tmp_path / name)
    assert str(tmp_path / name) in str(error.value)


def test_a_hopper_folder_holds_its_file_weights_and_manifest(tmp_path):
    folder = tmp_path / "big"
    hopper = make_hopper_folder(load_hopper(write(tmp_path / "big.json", BIG)), folder)
    assert hopper.folder == folder and hopper.source == folder / FOLDER_FILE and hopper.name == "big"
    assert manifest_entries(folder) == {FOLDER_FILE: sha256(folder / FOLDER_FILE)}
    assert load_hopper(folder) == hopper and hopper.weights("lstm.pt") is None
    (folder / "lstm.pt").write_bytes(b"weights")
    record_digest(folder / "lstm.pt")
    assert hopper.weights("lstm.pt") == folder / "lstm.pt" and "lstm.pt" in manifest_entries(folder)
    with pytest.raises(ValueError, match="plain file name"):
        hopper.weights("../big.json")
    assert NamedHopper(SlipParams(), "loose").weights("lstm.pt") is None


def test_a_changed_hopper_file_in_a_folder_is_refused(tmp_path):
    folder = tmp_path / "big"
    make_hopper_folder(NamedHopper(SlipParams(mass=12, leg_length=0.7, stiffness=6000), "big"), folder)
    write(folder / FOLDER_FILE, {**BIG, "mass": 13})
    with pytest.raises(ValueError, match=f"{folder / FOLDER_FILE} does not match its SHA-256 in .*{MANIFEST}"):
        load_hopper(folder)
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="has no hopper.json"):
        load_hopper(tmp_path / "empty")


def test_a_record_reads_back_to_the_same_hopper():
    hopper = paper_hopper()
    again = hopper_from_record(json.loads(json.dumps(hopper.to_record())), "results: hopper")
    assert (again.params, again.name, again.sha256) == (hopper.params, hopper.name, hopper.sha256)
    record = hopper.to_record()
    with pytest.raises(ValueError, match="results: hopper.params: unknown field 'spring'"):
        hopper_from_record({**record, "params": {**record["params"], "spring": 1}}, "results: hopper")
    with pytest.raises(ValueError, match="results: hopper.params: mass must be a positive"):
        hopper_from_record({**record, "params": {**record["params"], "mass": 0}}, "results: hopper")
    with pytest.raises(ValueError, match="results: hopper is missing the field 'params'"):
        hopper_from_record({"name": "x"}, "results: hopper")


def test_the_argument_type_is_one_flag_and_one_line(tmp_path, capsys):
    parser = ArgumentParser()
    parser.add_argument("--hopper", type=hopper_argument, default="paper")
    assert parser.parse_args([]).hopper == paper_hopper()
    assert parser.parse_args(["--hopper", str(write(tmp_path / "big.json", BIG))]).hopper.params.mass == 12.0
    for bad in (str(tmp_path / "missing.json"), str(write(tmp_path / "bad.json", {**BIG, "mass": 0}))):
        with pytest.raises(SystemExit) as stop:
            parser.parse_args(["--hopper", bad])
        err = capsys.readouterr().err
        assert stop.value.code == USAGE and err.count("\n") == 1 and bad in err
    with pytest.raises(argparse.ArgumentTypeError, match="packaged hoppers: paper"):
        hopper_argument("nonesuch")
