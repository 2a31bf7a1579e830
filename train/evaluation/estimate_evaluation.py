"""``sa-evaluate``: the quality of a model's estimates on labeled test data, against the naive
baseline. This is the number the project is judged by.

Test data is either ``render-dataset`` folders (up to ``--samples`` of their ``--split``, by
default the held-out "test" split, evenly spaced over the folders in order) or a folder of
material folders, rendered here by the torch renderer under the probes of ``--probes``
(train.data.map_samples; ``--samples`` of them, drawn from ``--seed``).

Each test image goes the way a user's photo goes: it is saved as an 8-bit PNG, gamma 1/2.2
encoded, and read back by train.data.photos.read_photo (gamma 2.2 decoding, centre square,
resize), then estimated by train.estimation.estimator.estimate with the network
train.estimation.network_choice gives it, exactly as ``sa-estimate`` does. The truth is box
filtered to the network's input size when the data has another.

Errors per sample (all on the paper's relative quantities, natural logs):
    albedo_rmse              RMSE of the relative diffuse albedo (pixels and channels)
    normal_angle_deg         mean angle between estimated and true normals
    log_specular_error       |log relative specular albedo error|, mean over the channels
    log_roughness_error      |log Ward alpha error|
    relit_rmse               estimate and truth rendered by the torch renderer under
                             ``relights`` probes the photo was not taken under (the data's
                             test-split probes when the folder holds them), each at a random
                             rotation, both scaled by the exposure of the truth's render and
                             clamped to [0, 1]; the RMSE over pixels, channels and relights
The naive baseline gets the same errors: albedo = the linearized photo scaled to mean 0.5, flat
normals, relative specular albedo 0.08 on every channel, Ward alpha 0.25 (the fixed lobe of
train.estimation.network_choice). The means, and each
mean of the model divided by the baseline's (``ratio``, below 1: the model is better), close
the report.

Where the relit error comes from (``relit_with_true``): the relit RMSE of the model's and of the
baseline's estimate with one part of it replaced by the truth (SWAPS: the albedo, the normals,
the specular albedo, the roughness, or specular albedo and roughness together). A part whose
swap lowers the relit error much is the part to get right.
"""

import dataclasses
import json
import math
import tempfile
from collections.abc import Collection, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from matplotlib.figure import Figure
from PIL import Image
from torch.nn import functional
from tqdm import tqdm

from render.common.atomic_files import atomic_path
from render.common.color import linear_to_srgb
from render.common.errors import InputError, require_output_folder
from render.common.exposure import expose
from render.common.probes import find_probes, load_probe
from render.common.resume import continue_folder, file_digest
from render.torch_renderer.renderer import ProbeBank, render, sphere_normals, ward_kernel
from train.data.labeled_dataset import LabeledDataset
from train.data.map_samples import MapSampler
from train.data.photos import PHOTO_GAMMA, read_photo
from train.estimation.estimator import choice_estimate
from train.estimation.network_choice import FIXED_ROUGHNESS, FIXED_SPECULAR, FixedNetwork
from train.training.losses import maps_at_size

ERRORS = ("albedo_rmse", "normal_angle_deg", "log_specular_error", "log_roughness_error",
          "relit_rmse")
SWAPS = {"albedo": ("albedo",), "normals": ("normal",), "specular": ("log_specular",),
         "roughness": ("log_roughness",),
         "specular+roughness": ("log_specular", "log_roughness")}
"""Parts of an estimate replaced by the truth for ``relit_with_true``: name -> parameters."""
FIGURE_ROWS = 6
MAY_CHANGE = ("out", "device")
"""Options a resumed evaluation may change (render.common.resume)."""
SWATCH_LIGHT = np.array([1.0, 1.0, 2.0]) / math.sqrt(6.0)
"""Direction of the directional light of the specular swatches (toward the light)."""


@dataclass(frozen=True)
class EvaluationConfig:
    out: str
    """Folder for results.json and figure.png."""
    probes: str
    """Folder of HDR probes: the relighting probes, and the lighting of ``materials``."""
    datasets: tuple = ()
    """render-dataset folders; their ``split``, concatenated in this order, is evaluated."""
    materials: str | None = None
    """Or a folder of material folders, rendered here under ``probes``."""
    split: str = "test"
    """The dataset's split: "test", "train" or "all"."""
    samples: int = 64
    """Samples rendered from ``materials``; of a dataset's split, at most this many, evenly
    spaced over it."""
    sample_size: int = 256
    """Side (px) of the samples rendered from ``materials``."""
    relights: int = 3
    seed: int = 0
    device: str = "cpu"


def test_samples(cfg: EvaluationConfig, bank: ProbeBank,
                 probe_names: Sequence[str]) -> list[tuple[np.ndarray, dict, str | None, str]]:
    """The test samples: (image (3, H, W) float32, truth dict of (1, ...) tensors, own probe
    name or None, sample name), as a list."""
    if bool(cfg.datasets) == (cfg.materials is not None):
        raise InputError(cfg.out, "give either dataset folders or a materials folder")
    if cfg.datasets:
        split = None if cfg.split == "all" else cfg.split
        items = []  # (dataset, index) over the datasets, in order
        for folder in cfg.datasets:
            data = LabeledDataset(folder, split)
            if len(data) == 0:
                raise InputError(folder, f"no samples in the '{cfg.split}' split")
            items += [(data, i) for i in range(len(data))]
        chosen = np.linspace(0, len(items) - 1, min(cfg.samples, len(items))).astype(int)
        samples = []
        for k in np.unique(chosen):
            data, i = items[int(k)]
            item = data[i]
            truth = {name: torch.as_tensor(item[name])[None] for name in
                     ("albedo", "normal", "log_specular", "log_roughness")}
            samples.append((item["image"], truth, item["provenance"]["probe"],
                            item["provenance"]["id"]))
        return samples
    sampler = MapSampler(cfg.materials, bank, range(len(bank)), cfg.sample_size,
                         2 * cfg.sample_size)
    rng = np.random.default_rng([cfg.seed, 1])
    samples = []
    for i in range(cfg.samples):
        batch = sampler.batch(rng, 1)
        provenance = batch["provenance"]
        truth = {name: batch[name] for name in
                 ("albedo", "normal", "log_specular", "log_roughness")}
        samples.append((batch["image"][0].cpu().numpy(), truth,
                        probe_names[provenance[0]["probe_index"]],
                        f"{provenance[0]['material']}_{i:03d}"))
    return samples


def as_photo_file(image: np.ndarray, folder: str | Path, name: str) -> Path:
    """Save a linear (3, H, W) image in [0, 1] as an 8-bit PNG encoded with gamma 1/2.2, the
    encoding train.data.photos.read_photo undoes; returns the path."""
    path = Path(folder) / f"{name}.png"
    encoded = np.clip(image.transpose(1, 2, 0), 0.0, 1.0) ** (1.0 / PHOTO_GAMMA)
    with atomic_path(path) as tmp:  # a failed write is one line naming the file
        Image.fromarray(np.round(encoded * 255.0).astype(np.uint8)).save(tmp, "PNG")
    return path


def model_estimate(choice: FixedNetwork,
                   photo: np.ndarray) -> tuple[dict[str, torch.Tensor], dict]:
    """The estimate sa-estimate would write, as a dict of (1, ...) tensors, and the dict that
    says which network made it (train.estimation.network_choice)."""
    svbrdf, _, chosen = choice_estimate(choice, photo)
    return {"albedo": torch.as_tensor(svbrdf.albedo.transpose(2, 0, 1))[None],
            "normal": torch.as_tensor(svbrdf.normal.transpose(2, 0, 1))[None],
            "log_specular": torch.as_tensor(np.log(svbrdf.specular))[None],
            "log_roughness": torch.tensor([[math.log(svbrdf.roughness)]])}, chosen


def naive_estimate(photo: np.ndarray) -> dict[str, torch.Tensor]:
    """The naive baseline of a (3, S, S) linear photo, as a dict of (1, ...) tensors."""
    image = torch.as_tensor(photo)[None].double()
    albedo = image * (0.5 / max(float(image.mean()), 1e-6))
    normal = torch.zeros_like(albedo)
    normal[:, 2] = 1.0
    return {"albedo": albedo.float(), "normal": normal.float(),
            "log_specular": torch.full((1, 3), math.log(FIXED_SPECULAR)),
            "log_roughness": torch.tensor([[math.log(FIXED_ROUGHNESS)]])}


def relit_under(parameters: dict[str, torch.Tensor], bank: ProbeBank, probe_index: torch.Tensor,
                rotation_deg: torch.Tensor) -> torch.Tensor:
    """HDR torch renders (R, 3, S, S) of one parameter set under R probes and rotations."""
    count = len(probe_index)
    return render(parameters["albedo"].expand(count, -1, -1, -1),
                  parameters["normal"].expand(count, -1, -1, -1),
                  torch.exp(parameters["log_specular"]).expand(count, -1),
                  torch.exp(parameters["log_roughness"][:, 0]).expand(count),
                  bank, probe_index, rotation_deg)


def relit_rmse(parameters: dict[str, torch.Tensor], bank: ProbeBank, probe_index: torch.Tensor,
               rotation_deg: torch.Tensor, truth_hdr: torch.Tensor,
               relit_truth: torch.Tensor) -> float:
    """Relit RMSE of ``parameters`` against the truth's exposed renders ``relit_truth``
    (exposed with the truth's HDR renders ``truth_hdr``)."""
    relit = expose(relit_under(parameters, bank, probe_index, rotation_deg), reference=truth_hdr)
    return float(torch.sqrt(torch.mean((relit - relit_truth) ** 2)))


def sample_errors(estimate_: dict[str, torch.Tensor], truth: dict[str, torch.Tensor],
                  relit_estimate: torch.Tensor, relit_truth: torch.Tensor) -> dict[str, float]:
    """The errors of the module docstring, as floats."""
    cosine = (estimate_["normal"] * truth["normal"]).sum(1).clamp(-1.0, 1.0)
    return {
        "albedo_rmse": float(torch.sqrt(torch.mean((estimate_["albedo"] - truth["albedo"]) ** 2))),
        "normal_angle_deg": float(torch.rad2deg(torch.acos(cosine)).mean()),
        "log_specular_error": float(torch.mean(torch.abs(estimate_["log_specular"]
                                                         - truth["log_specular"]))),
        "log_roughness_error": float(torch.abs(estimate_["log_roughness"]
                                               - truth["log_roughness"]).mean()),
        "relit_rmse": float(torch.sqrt(torch.mean((relit_estimate - relit_truth) ** 2))),
    }


def novel_lightings(rng: np.random.Generator, own_probe: str | None, probe_names: Sequence[str],
                    held_out: Collection[str], count: int) -> tuple[torch.Tensor, torch.Tensor]:
    """``count`` probe indices other than ``own_probe`` (among ``held_out`` names when any are
    in the folder) and rotations in degrees."""
    pool = [i for i, name in enumerate(probe_names) if name != own_probe
            and (not held_out or name in held_out)]
    if not pool:
        pool = [i for i, name in enumerate(probe_names) if name != own_probe] or [0]
    chosen = rng.choice(pool, size=count, replace=len(pool) < count)
    return torch.as_tensor(chosen), torch.as_tensor(rng.uniform(0.0, 360.0, size=count))


def held_out_probes(cfg: EvaluationConfig) -> set[str]:
    """Names of the datasets' test-split probes (none for a materials folder)."""
    return {record["probe"] for folder in cfg.datasets
            for record in LabeledDataset(folder, "test").samples}


def run(cfg: EvaluationConfig, choice: FixedNetwork) -> dict:
    """Evaluate the estimates of the networks ``choice`` gives
    (train.estimation.network_choice) on the data of ``cfg``; write results.json and
    figure.png into ``cfg.out``; return the report dict. Each sample's errors are kept in
    ``cfg.out/samples/<index>.json`` as they are measured, so a run that is cut off continues
    with the same options and model files (render.common.resume); the samples the figure shows
    are estimated again."""
    out = require_output_folder(cfg.out)
    probe_files = find_probes(cfg.probes)
    probe_names = [path.stem for path in probe_files]
    bank = ProbeBank([load_probe(path).radiance for path in probe_files], device=cfg.device)
    options = dataclasses.asdict(cfg) | {
        "models": {Path(path).name: file_digest(path) for path in choice.model_files},
        "fixed_lobe": choice.fixed_lobe,
        "probe_files": {path.name: file_digest(path) for path in probe_files}}
    samples = test_samples(cfg, bank, probe_names)
    continue_folder(out, options, MAY_CHANGE, "sa-evaluate")
    held_out = held_out_probes(cfg)
    size = choice.input_size
    records, figure_rows = [], []
    shown = set(np.linspace(0, len(samples) - 1, min(FIGURE_ROWS, len(samples))).astype(int))
    with tempfile.TemporaryDirectory() as photos:
        for i, (image, truth, own_probe, name) in enumerate(tqdm(samples, desc="sa-evaluate",
                                                                 unit="sample")):
            record_file = out / "samples" / f"{i:05d}.json"
            if record_file.is_file() and i not in shown:
                records.append(read_record(record_file))
                continue
            photo = read_photo(as_photo_file(image, photos, f"{i:05d}"), size)
            truth = maps_at_size({name: value.to(cfg.device) for name, value in truth.items()},
                                 size)
            probe_index, rotation = novel_lightings(np.random.default_rng([cfg.seed, 2, i]),
                                                    own_probe, probe_names, held_out,
                                                    cfg.relights)
            truth_hdr = relit_under(truth, bank, probe_index, rotation)
            relit_truth = expose(truth_hdr)
            estimated, chosen = model_estimate(choice, photo)
            record = {"sample": name, "photo_probe": own_probe,
                      "relight_probes": [probe_names[int(p)] for p in probe_index],
                      "network": chosen["model"]}  # "model" holds the model's errors
            record |= {key: value for key, value in chosen.items() if key != "model"}
            for kind, parameters in (("model", estimated), ("naive", naive_estimate(photo))):
                parameters = {name: value.to(cfg.device) for name, value in parameters.items()}
                relit = expose(relit_under(parameters, bank, probe_index, rotation),
                               reference=truth_hdr)
                record[kind] = sample_errors(parameters, truth, relit, relit_truth)
                record[kind]["relit_with_true"] = {
                    swap: relit_rmse(parameters | {n: truth[n] for n in names}, bank,
                                     probe_index, rotation, truth_hdr, relit_truth)
                    for swap, names in SWAPS.items()}
                if kind == "model" and i in shown:
                    figure_rows.append(figure_row(photo, parameters, truth, relit[0],
                                                  relit_truth[0]))
            text = json.dumps(record)
            with atomic_path(record_file) as tmp:
                tmp.write_text(text)
            records.append(json.loads(text))  # as a resumed run reads it back
    models = sorted({record["network"] for record in records})
    report = {"model": models[0] if len(models) == 1 else models,
              "data": list(cfg.datasets) or cfg.materials,
              "split": cfg.split if cfg.datasets else None,
              "samples": len(records), "mean": summary(records), "per_sample": records}
    with atomic_path(out / "results.json") as tmp:
        tmp.write_text(json.dumps(report, indent=1))
    write_figure(out / "figure.png", figure_rows)
    return report


def read_record(path: Path) -> dict:
    """A sample's errors as run wrote them."""
    try:
        return json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise InputError(path, f"cannot read a sample's errors ({error}); remove it to measure "
                               f"the sample again") from None


def summary(records: list[dict]) -> dict:
    """Means of the model's and the baseline's errors, and their ratios."""
    mean = {kind: {name: float(np.mean([r[kind][name] for r in records])) for name in ERRORS}
            for kind in ("model", "naive")}
    mean["ratio"] = {name: mean["model"][name] / mean["naive"][name]
                     if mean["naive"][name] > 0 else None for name in ERRORS}
    for kind in ("model", "naive"):
        mean[kind]["relit_with_true"] = {
            swap: float(np.mean([r[kind]["relit_with_true"][swap] for r in records]))
            for swap in SWAPS}
    return mean


def specular_swatch(log_specular: np.ndarray, log_roughness: float, size: int) -> np.ndarray:
    """A sphere (size, size, 3) of relative diffuse albedo 0.5 and the given homogeneous Ward
    specular, lit by one directional light (SWATCH_LIGHT) and seen from +z, linear RGB."""
    normal, mask = sphere_normals(size, dtype=torch.float64)  # (3, S, S), (1, S, S)
    light = torch.as_tensor(SWATCH_LIGHT)
    half = functional.normalize(light + torch.tensor([0.0, 0.0, 1.0], dtype=torch.float64), dim=0)
    cos_i = torch.einsum("chw,c->hw", normal, light)
    lobe = ward_kernel(torch.einsum("chw,c->hw", normal, half), cos_i, normal[2],
                       math.exp(float(log_roughness)))  # f_s cos_i / rho_s
    specular = torch.exp(torch.as_tensor(np.asarray(log_specular, np.float64)))
    radiance = (0.5 / math.pi * cos_i.clamp(min=0) + specular[:, None, None] * lobe) \
        * (math.pi * 1.2)
    swatch = torch.where(mask > 0, radiance, torch.full_like(radiance, 0.15))
    return swatch.permute(1, 2, 0).numpy().astype(np.float32)


def figure_row(photo: np.ndarray, estimate_: dict[str, torch.Tensor],
               truth: dict[str, torch.Tensor], relit_estimate: torch.Tensor,
               relit_truth: torch.Tensor) -> np.ndarray:
    """photo | albedo est | albedo true | normals est | normals true | swatch est | swatch
    true | relit est | relit true, as one (S, 9 S, 3) sRGB row in [0, 1]."""
    size = photo.shape[-1]

    def chw(tensor):
        return tensor.detach().cpu().numpy().transpose(1, 2, 0)

    panels = [linear_to_srgb(photo.transpose(1, 2, 0)),
              linear_to_srgb(chw(estimate_["albedo"][0])), linear_to_srgb(chw(truth["albedo"][0])),
              (chw(estimate_["normal"][0]) + 1) / 2, (chw(truth["normal"][0]) + 1) / 2]
    panels += [linear_to_srgb(specular_swatch(p["log_specular"][0].cpu().numpy(),
                                              p["log_roughness"][0, 0].item(), size))
               for p in (estimate_, truth)]
    panels += [linear_to_srgb(chw(relit_estimate)), linear_to_srgb(chw(relit_truth))]
    return np.concatenate(panels, axis=1)


def write_figure(path: Path, rows: list[np.ndarray]) -> None:
    """Stack the rows with a header line of column names; write an 8-bit PNG."""
    picture = np.clip(np.concatenate(rows, axis=0), 0, 1)
    names = ["photo", "albedo est", "albedo true", "normals est", "normals true",
             "specular est", "specular true", "relit est", "relit true"]
    height, width = picture.shape[:2]
    figure = Figure(figsize=(width / 100, height / 100 + 0.3), dpi=100)
    axis = figure.add_axes([0, 0, 1, height / (height + 30)])
    axis.imshow(picture)
    axis.axis("off")
    for k, name in enumerate(names):
        figure.text((k + 0.5) / len(names), 1 - 15 / (height + 30), name, ha="center",
                    va="center", fontsize=8)
    with atomic_path(path) as tmp:
        figure.savefig(tmp, format="png", dpi=100)
