"""What the fits of a part after training share (train.fits.joint_reading,
train.fits.albedo_correction): the photos they are fit on, their resumable work files, their
picture, and writing the model file with the fitted part.

Photos are rendered from material maps by train.data.map_samples.MapSampler and read back as
sa-evaluate reads its photos (an 8-bit PNG with gamma 1 / PHOTO_GAMMA): linear RGB in [0, 1],
(B, 3, S, S). Work files are torch files of tensors and plain containers, read with torch's
safe loader and used only under the options they were made with.
"""

import dataclasses
import json
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

import numpy as np
import torch
from matplotlib.figure import Figure
from tqdm import tqdm

from render.common.atomic_files import atomic_path
from render.common.errors import InputError
from render.common.probes import find_probes, load_probe
from render.torch_renderer.renderer import ProbeBank
from train.data.map_samples import MapSampler
from train.data.photos import PHOTO_GAMMA
from train.networks.model_files import FORMAT, load_network, model_metadata, save_model
from train.networks.svbrdf_net import SVBRDFNet

PHOTO_BATCH = 32
"""Photos rendered and read by the networks at once."""


def photo_round_trip(image: torch.Tensor) -> torch.Tensor:
    """(B, 3, S, S) linear images in [0, 1] -> as read back from an 8-bit PNG encoded with
    gamma 1 / PHOTO_GAMMA (sa-evaluate's photos)."""
    encoded = torch.round(image.clamp(0.0, 1.0) ** (1.0 / PHOTO_GAMMA) * 255.0) / 255.0
    return encoded ** PHOTO_GAMMA


def photo_batches(maps: str | Path, bank: ProbeBank, size: int, count: int,
                  rng: np.random.Generator,
                  mix_specular: bool = True) -> Iterator[tuple[dict, torch.Tensor]]:
    """``count`` labeled samples rendered from the material folders of ``maps`` under the
    probes of ``bank`` (MapSampler: ``size`` px crops of the maps resampled to twice that,
    mixed specular pairs unless ``mix_specular`` is False), drawn with ``rng`` in batches of
    PHOTO_BATCH: yields (batch, image), ``image`` the batch's photos as sa-evaluate reads them
    (photo_round_trip)."""
    sampler = MapSampler(maps, bank, range(len(bank)), size, 2 * size,
                         mix_specular=mix_specular)
    for start in tqdm(range(0, count, PHOTO_BATCH), desc="photos", unit="batch"):
        batch = sampler.batch(rng, min(PHOTO_BATCH, count - start))
        yield batch, photo_round_trip(batch["image"])


def saved_work(path: Path, options: dict) -> dict | None:
    """The data a fit saved at ``path`` (save_work) under the same ``options``, or None; read
    with torch's safe loader."""
    if not path.is_file():
        return None
    saved = torch.load(path, weights_only=True)
    return saved["data"] if saved["options"] == options else None


def save_work(path: Path, options: dict, data: dict) -> None:
    """Save a fit's ``data`` (tensors and plain containers) at ``path`` with the ``options``
    it depends on, atomically."""
    with atomic_path(path) as tmp:
        torch.save({"options": options, "data": data}, tmp)


def draw_fit(path: Path, losses: Sequence[float], checks: Sequence[tuple[int, float]],
             before: float, loss_label: str, check_labels: tuple[str, str],
             ylabel: str) -> None:
    """A fit's picture at ``path``: the loss per step (mean of 100 steps, ``loss_label``), the
    kept-out photos' error at the ``checks`` ((step, error) pairs) and ``before`` the fit,
    labelled ``check_labels`` (with, without)."""
    figure = Figure(figsize=(7, 4))
    axis = figure.subplots()
    window = min(100, len(losses))
    smooth = np.convolve(losses, np.ones(window) / window, mode="valid")
    axis.plot(np.arange(window, len(losses) + 1), smooth,
              label=f"{loss_label} (mean of {window} steps)")
    axis.plot([c[0] for c in checks], [c[1] for c in checks], "o-", label=check_labels[0])
    axis.axhline(before, color="grey", linestyle="--", label=check_labels[1])
    axis.set_xlabel("step")
    axis.set_ylabel(ylabel)
    axis.legend()
    figure.tight_layout()
    with atomic_path(path) as tmp:
        figure.savefig(tmp, format="png", dpi=100)


def fit_part_onto_model(model: str | Path, out: str | Path, part: str, probes: str | Path,
                        fit: Callable[[SVBRDFNet, ProbeBank], dict], command: str) -> dict:
    """Fit a part that a model takes after training (``part``, its NetworkConfig flag:
    ``joint_reading``, or ``albedo_correction`` of a photo-affine model) onto the model file
    ``model`` and write the model with it to ``out``: ``fit(net, bank)`` (``bank``: the
    probes of the folder ``probes``) fits the part in place and returns a report, kept in
    the file's metadata as ``<part>_fit``; ``command`` (the script and its options) is added
    to the recipe. Returns the report."""
    metadata = model_metadata(model, FORMAT, "model")
    net = load_network(model)
    try:
        net.config = dataclasses.replace(net.config, **{part: True})
    except ValueError as error:  # a part this network's configuration cannot take
        raise InputError(model, str(error)) from None
    report = fit(net, ProbeBank([load_probe(path).radiance for path in find_probes(probes)]))
    save_model(net, out, metadata | {"recipe": f"{metadata.get('recipe', '')}; then {command}",
                                     f"{part}_fit": json.dumps(report)})
    return report
