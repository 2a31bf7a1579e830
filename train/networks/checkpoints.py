"""Checkpoints: everything needed to resume a run exactly, or to estimate from photos.

A checkpoint (``checkpoints/step-000001000.pt``, torch.save of a dict) holds ``format``,
``config`` (the run's TrainConfig as a dict, the network configuration within it), ``model``,
``optimizer`` and ``scheduler`` state dicts, ``step`` (optimizer steps done), ``torch_rng``
and ``history`` (logged losses and evaluations). The other random choices are drawn from
generators seeded by (seed, step), so they need no state. Files are written under a temporary
name and renamed: a killed run loses at most the steps since its last checkpoint.
"""

import io
import re
from pathlib import Path
from typing import Any

import torch
from torch import nn

from render.common.atomic_files import atomic_path
from render.common.errors import InputError

FORMAT = "sa-svbrdf checkpoint 2"
"""Version 2: the albedo network ends in a softplus (version 1: a sigmoid)."""
KEEP = 3
NAME = re.compile(r"^step-(\d{9})\.pt$")


def save_checkpoint(folder: str | Path, state: dict[str, Any]) -> None:
    """Write ``state`` as ``step-<step>.pt`` in ``folder``; keep the newest KEEP files."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    with atomic_path(folder / f"step-{state['step']:09d}.pt") as tmp:
        buffer = io.BytesIO()  # serialized in memory: a failed write (disk full) is then an
        torch.save({"format": FORMAT, **state}, buffer)  # OSError that says why
        tmp.write_bytes(buffer.getbuffer())
    for old in checkpoint_files(folder)[:-KEEP]:
        old.unlink()


def checkpoint_files(folder: str | Path) -> list[Path]:
    """Checkpoint files of ``folder``, oldest first."""
    folder = Path(folder)
    if not folder.is_dir():
        return []
    return sorted(p for p in folder.iterdir() if NAME.match(p.name))


def checkpoint_step(checkpoint: Path) -> int:
    """Optimizer steps a checkpoint file holds, read from its name."""
    return int(NAME.match(checkpoint.name).group(1))


def newest_step(folder: str | Path) -> int:
    """Optimizer steps of the newest checkpoint in ``folder`` (0 without one)."""
    newest = checkpoint_files(folder)
    return checkpoint_step(newest[-1]) if newest else 0


def load_checkpoint(path: str | Path) -> dict[str, Any]:
    """The state dict of a checkpoint file, checked to be one of ours. It is read with torch's
    safe loader (``weights_only=True``), so a file carrying pickled code is refused without
    running it."""
    path = Path(path)
    if not path.is_file():
        raise InputError(path, "checkpoint not found")
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as error:  # torch raises many types for a corrupt or foreign file
        raise InputError(path, f"cannot read checkpoint safely ({type(error).__name__}: "
                               f"{_first_line(error)})") from None
    if not isinstance(state, dict) or state.get("format") != FORMAT:
        raise InputError(path, f"not an sa-svbrdf checkpoint (expected format '{FORMAT}')")
    return state


def _first_line(error):
    return (str(error).strip().splitlines() or [""])[0][:200]


def load_weights(net: nn.Module, state: dict[str, Any], path: str | Path) -> None:
    """Load the model weights of ``state`` into ``net``, with a clear error on a mismatch
    naming the first weights missing, unexpected or of another shape."""
    try:
        result = net.load_state_dict(state["model"], strict=False)
    except RuntimeError as error:  # a weight of another shape: torch names it on line 2
        lines = [line.strip() for line in str(error).strip().splitlines()]
        raise InputError(path, f"weights do not fit this network architecture "
                               f"({(lines[1:] or lines)[0][:200]})") from None
    problems = [f"{what} {', '.join(names[:2])}" + (f" and {len(names) - 2} more"
                                                    if len(names) > 2 else "")
                for what, names in (("missing", result.missing_keys),
                                    ("unexpected", result.unexpected_keys)) if names]
    if problems:
        raise InputError(path, f"weights do not fit this network architecture "
                               f"({'; '.join(problems)})")
