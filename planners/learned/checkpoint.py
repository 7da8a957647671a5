"""A model's checkpoint file: its format name, its config (a dataclass) and its weights, written atomically with the
digest in its folder's manifest and read back checked against it. The footstep models (``model.py``,
``spatial_model.py``) each name their format and class."""
from __future__ import annotations

from dataclasses import asdict

import torch

from drakeslip.jobs.files import atomic_write, first_line, load_weights, record_digest


def save_model_checkpoint(path, model, file_format: str, extra: dict | None = None) -> None:
    """Write ``model``'s config and weights as ``file_format`` atomically, and their digest in the folder's manifest."""
    payload = {"format": file_format, "config": asdict(model.config), "state_dict": model.state_dict(),
               **(extra or {})}
    with atomic_write(path) as f:
        torch.save(payload, f)
    record_digest(path)


def load_model_checkpoint(path, file_format: str, model_class, config_class, what: str) -> tuple:
    """(the model in eval mode, the file's payload) of a checkpoint of ``file_format`` (tensors and plain data only:
    ``weights_only``), checked against its folder's SHA-256 manifest; a changed, corrupt or mismatched file raises
    ValueError naming it and ``what`` it should be (e.g. "LSTM")."""
    payload = load_weights(path, f"{what} weights file")
    if not isinstance(payload, dict) or payload.get("format") != file_format:
        raise ValueError(f"{path} is not a drakeslip {what} checkpoint (missing format {file_format!r})")
    try:
        model = model_class(config_class(**payload["config"]))
        model.load_state_dict(payload["state_dict"])
    except (KeyError, TypeError, RuntimeError) as err:
        raise ValueError(f"{what} weights file {path} does not match the model: {first_line(err)}") from err
    model.eval()
    return model, payload
