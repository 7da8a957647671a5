"""Committed weights are checked against their SHA-256 manifest when loaded; a damaged or tampered file fails with
one line naming it; user files are checked by structure; checkpoints load without unpickling code."""
import shutil

import numpy as np
import pytest
import torch

from drakeslip import Terrain
from drakeslip.controller import DEFAULT_WEIGHTS as CONTROLLER_WEIGHTS
from drakeslip.controller import StepLengthController
from drakeslip.jobs.files import MANIFEST, check_digest, manifest_entries, record_digest, sha256
from planners.checkpoints import EXPERT_WEIGHTS, PAPER_WEIGHTS, RANKER_WEIGHTS, SUBCELL_WEIGHTS, WEIGHTS_DIR
from planners.learned.model import load_checkpoint
from planners.learned.ranker import FootholdRanker

COMMITTED = (CONTROLLER_WEIGHTS, PAPER_WEIGHTS, SUBCELL_WEIGHTS, EXPERT_WEIGHTS, RANKER_WEIGHTS)


@pytest.mark.parametrize("path", COMMITTED, ids=lambda p: p.name)
def test_every_committed_weights_file_is_in_its_manifest_and_matches(path):
    assert manifest_entries(path.parent)[path.name] == sha256(path)
    assert check_digest(path)


def tampered_copy(tmp_path, path, tensor_name=None):
    """The file and its folder's manifest copied to tmp_path, with 50 bytes flipped (inside ``tensor_name``'s
    stored bytes when given)."""
    shutil.copy(path.parent / MANIFEST, tmp_path / MANIFEST)
    copy = tmp_path / path.name
    data = bytearray(path.read_bytes())
    if tensor_name is None:
        start = len(data) // 2
    else:  # a tensor's bytes sit in the archive as data/<key>; find it through its distinctive values
        values = torch.load(path, weights_only=True)["state_dict"][tensor_name].numpy().tobytes()
        start = bytes(data).index(values[:64])
    for i in range(start, start + 50):
        data[i] ^= 0xFF
    copy.write_bytes(bytes(data))
    return copy


def test_flipped_bytes_in_the_lstm_weights_are_refused_in_one_line(tmp_path):
    copy = tampered_copy(tmp_path, EXPERT_WEIGHTS, "lstm.weight_hh_l0")
    torch.load(copy, weights_only=True)  # still a readable checkpoint: only the digest can tell
    with pytest.raises(ValueError) as err:
        load_checkpoint(copy)
    message = str(err.value)
    assert "\n" not in message and str(copy) in message and "does not match its SHA-256" in message


@pytest.mark.parametrize("path, load", [(CONTROLLER_WEIGHTS, StepLengthController.load), (RANKER_WEIGHTS, FootholdRanker),
                                        (PAPER_WEIGHTS, load_checkpoint)], ids=("controller", "ranker", "lstm"))
def test_every_loader_checks_the_digest(tmp_path, path, load):
    with pytest.raises(ValueError, match="does not match its SHA-256"):
        load(tampered_copy(tmp_path, path))


def test_a_users_own_weights_are_checked_by_structure(tmp_path):
    """No manifest: the loader checks what the file holds (format, shapes) and names the file."""
    payload = torch.load(PAPER_WEIGHTS, weights_only=True)
    payload["state_dict"]["head.weight"] = payload["state_dict"]["head.weight"][:, :10]
    torch.save(payload, tmp_path / "mine.pt")
    assert not check_digest(tmp_path / "mine.pt")
    with pytest.raises(ValueError, match=r"mine.pt does not match the model"):
        load_checkpoint(tmp_path / "mine.pt")
    torch.save({"format": "drakeslip-lstm/1", "config": {}, "state_dict": {}, "code": np.float64}, tmp_path / "x.pt")
    with pytest.raises(ValueError, match=r"cannot read LSTM weights file .*x.pt: not a torch file of tensors and plain data"):
        load_checkpoint(tmp_path / "x.pt")  # an object that is not plain data is not unpickled


def test_saving_weights_beside_a_manifest_updates_its_entry(tmp_path):
    shutil.copy(WEIGHTS_DIR / MANIFEST, tmp_path / MANIFEST)
    controller = StepLengthController.load_default()
    controller.save(tmp_path / "controller.pt")
    assert manifest_entries(tmp_path)["controller.pt"] == sha256(tmp_path / "controller.pt")
    flat = Terrain.flat()
    assert StepLengthController.load(tmp_path / "controller.pt").leg_angle((0, 1, 2), 0.5, flat) == \
        controller.leg_angle((0, 1, 2), 0.5, flat)
    record_digest(tmp_path / "controller.pt")  # idempotent
    assert set(manifest_entries(tmp_path)) == set(manifest_entries(WEIGHTS_DIR)) | {"controller.pt"}
