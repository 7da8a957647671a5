"""The torch device a training script runs on, from its ``--device`` flag: ``auto`` is the GPU when torch sees
one (``cuda``), else the CPU; a named device is checked before any work starts."""
from __future__ import annotations

DEVICE_HELP = "torch device: cpu, cuda, cuda:N, or auto (cuda when available, else cpu)"


def torch_device(name: str) -> str:
    """The device ``name`` asks for, as torch spells it; ValueError naming it when torch does not know it, when it
    is neither a CPU nor a CUDA device, or when no such CUDA device is on this machine."""
    import torch

    if name == "auto":
        return "cuda" if torch.cuda.is_available() else "cpu"
    try:
        device = torch.device(name)
    except (RuntimeError, TypeError):
        raise ValueError(f"unknown torch device {name!r}; use cpu, cuda, cuda:N or auto") from None
    if device.type not in ("cpu", "cuda"):
        raise ValueError(f"{name!r}: training runs on cpu or cuda devices, not {device.type}")
    if device.type == "cuda":
        if not torch.cuda.is_available():
            raise ValueError(f"{name!r} needs CUDA, which is not available on this machine")
        if device.index is not None and device.index >= torch.cuda.device_count():
            raise ValueError(f"{name!r}: this machine has {torch.cuda.device_count()} CUDA device(s), numbered "
                             "from 0")
    return str(device)
