"""Model files: the three forms a model is given in, each read without executing code.

- a run folder of ``sa-train`` (its newest checkpoint);
- an ``sa-train`` checkpoint (``.pt``), read by train.networks.checkpoints with torch's safe loader
  (``weights_only=True``: tensors and plain containers only, a pickled callable is refused);
- a shipped model (``.safetensors``): the network's weights in float16 and, in the file's
  metadata, ``format`` (FORMAT), ``network`` (the NetworkConfig as JSON) and free-form
  provenance (``class``, ``recipe``, ...). safetensors holds tensors and strings only.

The shipped models live in ``models/`` of the repository (models/README.md is their card),
installed as the data package SHIPPED_MODELS: ``svbrdf-<name>.safetensors`` for each name of
SHIPPED.
"""

import json
from pathlib import Path
from typing import Any

import torch
from safetensors import SafetensorError, safe_open
from safetensors.torch import load_file, save_file
from torch import nn

from render.common.atomic_files import atomic_path
from render.common.errors import InputError
from render.common.package_data import installed_file
from train.networks.checkpoints import checkpoint_files, load_checkpoint, load_weights
from train.networks.svbrdf_net import NetworkConfig, SVBRDFNet

FORMAT = "sa-svbrdf model 1"
SHIPPED_MODELS = "train.shipped_models"
"""The data package of the shipped files: the repository's ``models/`` (pyproject.toml)."""
SHIPPED = ("wood", "plastic", "metal")
"""One network per material class, as the paper trains them."""


def shipped_model_path(name: str) -> Path:
    """The file of shipped model ``name`` (one of SHIPPED)."""
    if name not in SHIPPED:
        raise ValueError(f"unknown model class '{name}' (expected one of {', '.join(SHIPPED)})")
    return installed_file(SHIPPED_MODELS, f"svbrdf-{name}.safetensors")


def save_model(net: SVBRDFNet, path: str | Path, metadata: dict[str, Any]) -> None:
    """Write ``net``'s weights (floats as float16) and ``metadata`` (str -> JSON-able) as a
    shipped model file; its ``format`` and ``network`` are the file's own, whatever
    ``metadata`` (perhaps copied from another file) holds under those keys."""
    save_weights_file(net, path, metadata | {"format": FORMAT})


def save_weights_file(module: nn.Module, path: str | Path, metadata: dict[str, Any]) -> None:
    """Write a module's weights (floats as float16), ``metadata`` (str -> JSON-able) and its
    ``config`` as ``network`` (in place of any ``network`` of ``metadata``) as a safetensors
    file, atomically, readable by everyone (safetensors creates it owner-only)."""
    tensors = {name: (value.half() if value.is_floating_point() else value).contiguous().cpu()
               for name, value in module.state_dict().items()}
    header = {key: value if isinstance(value, str) else json.dumps(value)
              for key, value in metadata.items()}
    header["network"] = json.dumps(vars(module.config))
    with atomic_path(Path(path)) as tmp:
        save_file(tensors, str(tmp), metadata=header)
        tmp.chmod(0o644)


def model_metadata(path: str | Path, file_format: str, what: str) -> dict[str, str]:
    """The metadata dict (str -> str) of the safetensors file ``path`` (a shipped model), which
    must exist and declare ``file_format``; ``what`` names the kind of file in the one-line
    errors."""
    path = Path(path)
    if not path.is_file():
        raise InputError(path, f"{what} file not found")
    try:
        with safe_open(str(path), framework="pt") as file:
            metadata = file.metadata() or {}
    except (SafetensorError, OSError, ValueError) as error:
        raise InputError(path, f"cannot read safetensors file ({error})") from None
    if metadata.get("format") != file_format:
        raise InputError(path, f"not an sa-svbrdf {what} (expected format '{file_format}')")
    return metadata


def load_network(path: str | Path, device: str | torch.device = "cpu") -> SVBRDFNet:
    """The SVBRDF-net of a shipped model, checkpoint or run folder, in evaluation mode and
    float32 on ``device``; ``net.source`` names the file it came from."""
    path = Path(path)
    if path.is_dir():
        newest = checkpoint_files(path / "checkpoints")
        if not newest:
            raise InputError(path, "run folder without checkpoints")
        path = newest[-1]
    if path.suffix == ".safetensors":
        net = _shipped_network(path)
    else:
        state = load_checkpoint(path)
        try:
            network = NetworkConfig(**state["config"]["network"])
        except (KeyError, TypeError) as error:
            raise InputError(path, f"checkpoint has no valid configuration ({error})") from None
        net = SVBRDFNet(network)
        load_weights(net, state, path)
    net.source = str(path)
    return net.to(device).eval()


def shipped_network_config(path: str | Path) -> NetworkConfig:
    """The NetworkConfig of a shipped model file, read from its metadata (no weights)."""
    metadata = model_metadata(path, FORMAT, "model")
    try:
        return NetworkConfig(**json.loads(metadata["network"]))
    except (KeyError, TypeError, ValueError) as error:
        raise InputError(path, f"model has no valid network configuration ({error})") from None


def load_weights_file(module: nn.Module, path: str | Path) -> None:
    """Load the (float16) weights of a safetensors file into ``module`` as float32."""
    weights = {name: value.float() if value.is_floating_point() else value
               for name, value in load_file(str(path)).items()}
    load_weights(module, {"model": weights}, path)


def _shipped_network(path):
    net = SVBRDFNet(shipped_network_config(path))
    load_weights_file(net, path)
    return net
