"""Fitting the JointReading head (train.networks.svbrdf_net) of an SVBRDF-net.

The homogeneous network reads the specular albedo and roughness, a photo-affine albedo
network the reflection's share of the photo; on a flat glossy sample both read the same
offset, which a lighter albedo explains as well as a stronger reflection. The head reads the
five values together (beside a map albedo network, the homogeneous network's four), with
quantiles of the photo's values (train.networks.svbrdf_net.photo_statistics), and is fit, the
networks frozen, on the evaluation's relit error (train.evaluation.estimate_evaluation),
which a network trained on the parameters' own errors does not weigh (a roughness read too
low, a sharp highlight where the truth's is broad, costs more relit error than one read as
much too high):

1. **Photos.** ``photos`` labeled samples rendered from a folder of material maps under
   training probes (train.data.map_samples.MapSampler, 256 px; mixed specular pairs unless
   ``mix_specular`` is off: then each set's own pair, where the generator ties the two to
   the set's look, as wood's finish does), rounded to 8 bits after gamma 1/2.2 encoding as
   sa-evaluate's PNG photos are, then read by the frozen networks: their readings and the
   photo statistics. The photo (beside a map albedo network, the network's albedo instead)
   and the truth's maps are kept box filtered to RELIT_SIZE px.
2. **Relights.** Each photo ``relights`` times under another probe of the bank at a random
   rotation: the truth rendered by the torch renderer at RELIT_SIZE px, auto-exposed (its
   scale kept) and clamped to [0, 1].
3. **The estimate's render without rendering.** Under flat normals a sample's radiance is
   uniform and does not change with the probe's rotation about +z: per probe, the diffuse
   radiance of albedo 1 and the specular radiance of specular albedo 1 on a grid of Ward
   alphas (ALPHA_GRID, interpolated in log alpha) give it. The estimate's relit image is its
   albedo times the first plus its specular albedo times the second, exposed
   with the truth's scale: a step costs no render (a render of the network's normals would
   cost about a second per minibatch on the project's CPU). The estimate's albedo is the
   photo-affine albedo of the corrected share, or the map network's (which the head does not
   change). The networks' normals are left out of the fit (the plastic network's are nearly
   flat: its normal angle error is 1.05x the flat baseline's; the wood network's 0.75x);
   sa-evaluate judges the head with them.
4. **Fit.** Adam (lr 1e-3, weight decay 1e-4) on the relit RMSE (the estimate's clamp leaks,
   train.training.losses.RELIT_CLAMP_LEAK), minibatches of BATCH relights, ``steps`` steps. A
   tenth of the photos (CHECK_SHARE) is kept out of the fit; their relit error, with and
   without the head, is reported and drawn beside the loss (``WORK/fit.png``).

Steps 1 and 2 are the slow part (about 0.1 s per photo on the project's 2-core CPU); their
result is saved (``WORK/prepared.pt``, read back with torch's safe loader), so a fit cut off
after them starts from it when run again with the same options.
"""

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from torch.nn import functional
from tqdm import tqdm

from render.common.exposure import exposure_scales
from render.torch_renderer.renderer import ProbeBank, render
from train.fits.part_fitting import draw_fit, photo_batches, save_work, saved_work
from train.networks.svbrdf_net import (
    JointReading,
    SVBRDFNet,
    photo_affine_albedo,
    photo_statistics,
)
from train.training.losses import RELIT_CLAMP_LEAK, clamped_relit_rmse, maps_at_size

RELIT_SIZE = 32
"""Side (px) of the relit images the head is fit on."""
ALPHA_GRID = torch.exp(torch.linspace(math.log(0.02), 0.0, 33))
"""Ward alphas of the specular radiance tables (the model's range, evenly in log)."""
BATCH = 256
CHECK_SHARE = 0.1
"""Share of the photos kept out of the fit to report it on."""


@dataclass(frozen=True)
class FitConfig:
    work: str
    """Folder for prepared.pt and fit.png."""
    maps: str
    """Folder of material folders the photos are rendered from."""
    photos: int = 9600
    """Photos rendered (CHECK_SHARE of them kept out of the fit)."""
    relights: int = 2
    """Relights per photo, each under another training probe."""
    mix_specular: bool = True
    """Photos of mixed specular pairs (train.data.map_samples) or of each set's own."""
    steps: int = 10000
    seed: int = 0


def prepare(cfg: FitConfig, net: SVBRDFNet, bank: ProbeBank) -> dict[str, torch.Tensor]:
    """Steps 1 and 2 of the module docstring: a dict of tensors (readings (N, inputs of the
    head), photo (N, 3, s, s), or beside a map albedo network albedo (N, 3, s, s) instead,
    relit_probe / exposure / relit (N R, ...), photo_of_relight (N R,))."""
    rng = np.random.default_rng([cfg.seed, 1])
    readings, photos, truths = [], [], []
    share = net.joint.reads_share
    for batch, image in photo_batches(cfg.maps, bank, net.config.input_size, cfg.photos, rng,
                                      cfg.mix_specular):
        with torch.no_grad():
            homogeneous = net.homogeneous(image)
            logit = net.albedo.affine(image) if share else None
            readings.append(net.joint.readings(homogeneous[:, :3], homogeneous[:, 3:], logit,
                                               photo_statistics(image)))
            kept = image if share else net.albedo(image)
        photos.append(functional.interpolate(kept, size=RELIT_SIZE, mode="area"))
        truths.append(maps_at_size({name: batch[name] for name in
                                    ("albedo", "normal", "log_specular", "log_roughness")},
                                   RELIT_SIZE) | {"probe": torch.as_tensor(
                                       [p["probe_index"] for p in batch["provenance"]])})
    truth = {name: torch.cat([t[name] for t in truths]) for name in truths[0]}
    relit_probe, exposure, relit, photo_of_relight = [], [], [], []
    for _ in tqdm(range(cfg.relights), desc="relights"):
        for start in range(0, cfg.photos, BATCH):
            index = torch.arange(start, min(start + BATCH, cfg.photos))
            other = torch.as_tensor(rng.integers(len(bank) - 1, size=len(index)))
            probe = other + (other >= truth["probe"][index]).long()  # any probe but its own
            rotation = torch.as_tensor(rng.uniform(0.0, 360.0, size=len(index)),
                                       dtype=torch.float32)
            with torch.no_grad():
                hdr = render(truth["albedo"][index], truth["normal"][index],
                             truth["log_specular"][index].exp(),
                             truth["log_roughness"][index, 0].exp().clamp(0.02, 1.0),
                             bank, probe, rotation)
            scale = exposure_scales(hdr)
            relit_probe.append(probe)
            exposure.append(scale)
            relit.append((hdr * scale[:, None, None, None]).clamp(0.0, 1.0))
            photo_of_relight.append(index)
    return {"readings": torch.cat(readings), "photo" if share else "albedo": torch.cat(photos),
            "relit_probe": torch.cat(relit_probe), "exposure": torch.cat(exposure),
            "relit": torch.cat(relit), "photo_of_relight": torch.cat(photo_of_relight)}


def flat_radiance_tables(bank: ProbeBank) -> tuple[torch.Tensor, torch.Tensor]:
    """(diffuse (P, 3), specular (P, len(ALPHA_GRID), 3)): per probe of ``bank``, the
    radiance of a flat sample of albedo 1 (no specular) and of specular albedo 1 (no diffuse)
    at each alpha of ALPHA_GRID, seen from +z."""
    count, side = len(bank), 4
    flat = torch.zeros(count, 3, side, side)
    flat[:, 2] = 1.0
    index = torch.arange(count)
    with torch.no_grad():
        diffuse = render(torch.ones(count, 3, side, side), flat, torch.zeros(count, 3),
                         torch.full((count,), 0.25), bank, index).mean((2, 3))
        specular = torch.stack([render(torch.zeros(count, 3, side, side), flat,
                                       torch.ones(count, 3), torch.full((count,), float(a)),
                                       bank, index).mean((2, 3)) for a in ALPHA_GRID], 1)
    return diffuse, specular


def specular_at(tables: torch.Tensor, log_roughness: torch.Tensor) -> torch.Tensor:
    """(B, 3): ``tables`` (B, len(ALPHA_GRID), 3) interpolated linearly in log alpha at
    ``log_roughness`` (B,), clamped to the grid."""
    grid = torch.log(ALPHA_GRID)
    position = (log_roughness.clamp(grid[0], grid[-1]) - grid[0]) / (grid[1] - grid[0])
    low = position.detach().floor().clamp(max=len(grid) - 2).long()
    weight = (position - low)[:, None]
    rows = torch.arange(len(position))
    return tables[rows, low] * (1.0 - weight) + tables[rows, low + 1] * weight


def relit_errors(head: JointReading | None, prepared: dict[str, torch.Tensor],
                 tables: tuple[torch.Tensor, torch.Tensor], relights: torch.Tensor,
                 leak: float = 0.0) -> torch.Tensor:
    """Relit RMSE (len(relights),) of the head's corrected readings for the given relight
    rows of ``prepared`` (of a photo-affine network where it holds the photos, else of a map
    albedo network); ``head`` None: the networks' own readings."""
    photo = prepared["photo_of_relight"][relights]
    readings = prepared["readings"][photo]
    if head is not None:
        log_specular, log_roughness, logit = head.corrected(readings)
    else:  # the logit column is read only where the photos are (a photo-affine network)
        log_specular, log_roughness, logit = readings[:, :3], readings[:, 3:4], readings[:, 4:5]
    albedo = (photo_affine_albedo(logit, prepared["photo"][photo]) if "photo" in prepared
              else prepared["albedo"][photo])
    diffuse, specular = (table[prepared["relit_probe"][relights]] for table in tables)
    radiance = albedo * diffuse[:, :, None, None] + (
        log_specular.exp() * specular_at(specular, log_roughness[:, 0]))[:, :, None, None]
    exposed = radiance * prepared["exposure"][relights][:, None, None, None]
    return clamped_relit_rmse(exposed, prepared["relit"][relights], leak)


def fit(cfg: FitConfig, net: SVBRDFNet, bank: ProbeBank) -> dict:
    """Fit ``net.joint`` (a JointReading, replaced by a fresh one) as the module docstring
    says; returns a report dict (relit error of the check photos with and without it)."""
    work = Path(cfg.work)
    work.mkdir(parents=True, exist_ok=True)
    options = {"maps": cfg.maps, "photos": cfg.photos, "relights": cfg.relights,
               "seed": cfg.seed, "model": getattr(net, "source", None), "probes": len(bank),
               "mix_specular": cfg.mix_specular}
    """What the prepared data depends on."""
    prepared = saved_work(work / "prepared.pt", options)
    net.joint = JointReading(reads_share=net.config.albedo_network == "photo-affine")
    if prepared is None:
        prepared = prepare(cfg, net, bank)
        save_work(work / "prepared.pt", options, prepared)
    head = net.joint
    check_count = max(1, round(CHECK_SHARE * cfg.photos))
    is_check = prepared["photo_of_relight"] >= cfg.photos - check_count
    train_rows, check_rows = torch.nonzero(~is_check)[:, 0], torch.nonzero(is_check)[:, 0]
    fitted = prepared["readings"][: cfg.photos - check_count]
    head.mean.copy_(fitted.mean(0))
    head.scale.copy_(fitted.std(0) + 1e-3)
    tables = flat_radiance_tables(bank)
    with torch.no_grad():
        before = relit_errors(None, prepared, tables, check_rows).mean().item()
    optimizer = torch.optim.Adam(head.mlp.parameters(), lr=1e-3, weight_decay=1e-4)
    rng = np.random.default_rng([cfg.seed, 2])
    losses, checks = [], []
    for step in tqdm(range(1, cfg.steps + 1), desc="fit", unit="step"):
        rows = train_rows[torch.as_tensor(rng.integers(len(train_rows), size=BATCH))]
        loss = relit_errors(head, prepared, tables, rows, leak=RELIT_CLAMP_LEAK).mean()
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        losses.append(loss.item())
        if step % 500 == 0 or step == cfg.steps:
            with torch.no_grad():
                checks.append((step, relit_errors(head, prepared, tables,
                                                  check_rows).mean().item()))
    draw_fit(work / "fit.png", losses, checks, before, "fit loss",
             ("check photos, with the head", "check photos, networks alone"),
             f"relit RMSE ({RELIT_SIZE} px, flat normals)")
    return {"check_photos": check_count, "check_relit_before": before,
            "check_relit_after": checks[-1][1], "check_ratio": checks[-1][1] / before}
