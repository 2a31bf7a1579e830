"""Fitting the AlbedoCorrection (train.networks.svbrdf_net) of a photo-affine SVBRDF-net.

The photo-affine albedo is the photo less a grey offset: it keeps, beside the albedo, what
else the photo shows pixel by pixel (the shading of a fine relief, its glints). The
correction, a small local network, learns where a pixel's value is albedo and where it is not,
from the albedo and its neighbourhood; it is fit after the other networks, which stay frozen:

1. **Photos.** ``photos`` labeled samples rendered from a folder of material maps under
   training probes (train.data.map_samples.MapSampler, mixed specular pairs, at the network's input
   size), rounded to 8 bits as sa-evaluate's PNG photos are (train.fits.part_fitting
   .photo_batches), each read by the frozen networks: its photo-affine albedo (through the
   JointReading head where the network has one), kept in float16 beside the truth's albedo.
2. **Fit.** Adam on the albedo RMSE of each photo (before the correction's scaling to mean
   0.5: the truth's mean is about 0.5), minibatches of BATCH crops of CROP pixels (one crop
   position per minibatch; the whole photo where it is smaller), ``steps`` steps, the
   learning rate halved at each step of ``halvings``. A tenth of the photos (CHECK_SHARE) is
   kept out of the fit; their whole-photo albedo RMSE, with and without the correction, is
   reported and drawn beside the loss (``WORK/fit.png``).

Step 1 takes 0.12 to 0.19 s per photo on the project's 2-core CPU, step 2 about 0.23 s per
step; both save their state in WORK (``prepared.pt``, and ``fit.pt`` every CHECKPOINT_EVERY
steps; train.fits.part_fitting.save_work, read back with torch's safe loader), so a fit cut off
starts again where it stopped when run with the same options, and a finished fit run again
with more ``steps`` goes on. Each step's minibatch is drawn from its own seed (``seed``,
step) and the fresh correction's weights from ``seed``, so a resumed fit draws what an uncut
one would.
"""

from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from render.torch_renderer.renderer import ProbeBank
from train.fits.part_fitting import draw_fit, photo_batches, save_work, saved_work
from train.networks.svbrdf_net import AlbedoCorrection, SVBRDFNet

BATCH = 16
"""Crops per minibatch."""
CROP = 96
"""Side of the crops (px)."""
CHECK_SHARE = 0.1
"""Share of the photos kept out of the fit to report it on."""
CHECKPOINT_EVERY = 250
"""Steps between saved states (and kept-out checks)."""


@dataclass(frozen=True)
class FitConfig:
    work: str
    """Folder for prepared.pt, fit.pt and fit.png."""
    maps: str
    """Folder of material folders the photos are rendered from."""
    photos: int = 3200
    """Photos rendered (CHECK_SHARE of them kept out of the fit)."""
    steps: int = 8000
    learning_rate: float = 1e-3
    halvings: tuple = (3000,)
    """Steps at which the learning rate is halved."""
    seed: int = 0


def prepare(cfg: FitConfig, net: SVBRDFNet, bank: ProbeBank) -> dict[str, torch.Tensor]:
    """Step 1 of the module docstring: a dict of float16 tensors ``estimate`` (the frozen
    networks' photo-affine albedo) and ``truth``, each (photos, 3, S, S)."""
    rng = np.random.default_rng([cfg.seed, 1])
    estimates, truths = [], []
    for batch, image in photo_batches(cfg.maps, bank, net.config.input_size, cfg.photos, rng):
        with torch.no_grad():
            estimates.append(net.photo_affine_albedo(image, image).half())
        truths.append(batch["albedo"].half())
    return {"estimate": torch.cat(estimates), "truth": torch.cat(truths)}


def albedo_rmse(albedo: torch.Tensor, truth: torch.Tensor) -> torch.Tensor:
    """(B,): RMSE over pixels and channels of (B, 3, H, W) albedos."""
    return torch.sqrt(((albedo - truth) ** 2).mean((1, 2, 3)))


def corrected(correction: AlbedoCorrection, albedo: torch.Tensor) -> torch.Tensor:
    """``albedo`` times the correction's gain, not scaled again (the fit's estimate)."""
    return albedo * torch.exp(correction.log_gain(albedo))


def check_errors(correction: AlbedoCorrection, prepared: dict[str, torch.Tensor],
                 rows: torch.Tensor) -> tuple[float, float]:
    """Mean whole-photo albedo RMSE of the photos ``rows`` of ``prepared``: (with the
    correction, without it)."""
    with_, without = [], []
    with torch.no_grad():
        for start in range(0, len(rows), BATCH):
            index = rows[start:start + BATCH]
            albedo = prepared["estimate"][index].float()
            truth = prepared["truth"][index].float()
            with_.append(albedo_rmse(corrected(correction, albedo), truth))
            without.append(albedo_rmse(albedo, truth))
    return torch.cat(with_).mean().item(), torch.cat(without).mean().item()


def fit(cfg: FitConfig, net: SVBRDFNet, bank: ProbeBank) -> dict:
    """Fit ``net.correction`` (an AlbedoCorrection, replaced by a fresh one unless a saved
    fit of the same options resumes) as the module docstring says; returns a report dict (the
    kept-out photos' albedo RMSE with and without it)."""
    work = Path(cfg.work)
    work.mkdir(parents=True, exist_ok=True)
    options = {"maps": cfg.maps, "photos": cfg.photos, "seed": cfg.seed,
               "model": getattr(net, "source", None), "probes": len(bank)}
    """What the prepared data depends on."""
    prepared = saved_work(work / "prepared.pt", options)
    if prepared is None:
        prepared = prepare(cfg, net, bank)
        save_work(work / "prepared.pt", options, prepared)
    fit_options = options | {key: value for key, value in asdict(cfg).items()
                             if key not in ("work", "steps")}
    with torch.random.fork_rng():
        torch.manual_seed(cfg.seed)
        net.correction = correction = AlbedoCorrection()
    optimizer = torch.optim.Adam(correction.parameters(), lr=cfg.learning_rate)
    state = saved_work(work / "fit.pt", fit_options) or {"step": 0, "losses": [], "checks": []}
    if state["step"] > cfg.steps:
        raise ValueError(f"{work / 'fit.pt'}: a fit of {state['step']} steps, more than the "
                         f"{cfg.steps} asked for")
    if state["step"]:
        correction.load_state_dict(state["correction"])
        optimizer.load_state_dict(state["optimizer"])
    check_count = max(1, round(CHECK_SHARE * cfg.photos))
    fitted = cfg.photos - check_count
    check_rows = torch.arange(fitted, cfg.photos)
    before = check_errors(correction, prepared, check_rows)[1]
    side = prepared["estimate"].shape[-1]
    crop = min(CROP, side)
    losses, checks = list(state["losses"]), list(state["checks"])
    for step in tqdm(range(state["step"] + 1, cfg.steps + 1), desc="fit", unit="step",
                     initial=state["step"], total=cfg.steps, mininterval=30):
        for group in optimizer.param_groups:
            group["lr"] = cfg.learning_rate * 0.5 ** sum(step > h for h in cfg.halvings)
        rng = np.random.default_rng([cfg.seed, 2, step])
        index = torch.as_tensor(rng.integers(fitted, size=BATCH))
        top, left = rng.integers(0, side - crop + 1, size=2)
        window = (index, slice(None), slice(top, top + crop), slice(left, left + crop))
        loss = albedo_rmse(corrected(correction, prepared["estimate"][window].float()),
                           prepared["truth"][window].float()).mean()
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        losses.append(loss.item())
        if step % CHECKPOINT_EVERY == 0 or step == cfg.steps:
            checks.append((step, check_errors(correction, prepared, check_rows)[0]))
            save_work(work / "fit.pt", fit_options, {
                "step": step, "losses": losses, "checks": checks,
                "correction": correction.state_dict(), "optimizer": optimizer.state_dict()})
    draw_fit(work / "fit.png", losses, checks, before, f"fit loss, {crop} px crops",
             ("kept-out photos, corrected", "kept-out photos, uncorrected"),
             "albedo RMSE (relative albedo)")
    return {"check_photos": check_count, "check_albedo_rmse_before": before,
            "check_albedo_rmse_after": checks[-1][1], "check_ratio": checks[-1][1] / before}
