"""How much a single photo can tell about the specular pair: for each test sample, other
materials whose photo looks the same, and how differently they relight.

For each sample of the test data (as ``sa-evaluate`` draws it: ``render-dataset`` folders or a
folder of material folders with probes) the truth's normal map is kept and its homogeneous
specular lobe replaced by an alternative: a Ward alpha from ``ALPHAS`` and the true specular
colour times a factor t (searched on the grid ``FACTORS``), with either the true albedo or the
true albedo rescaled and offset (scale * albedo + offset, least squares given t: a brighter
specular reflection can stand in for a lighter albedo). Of each kind and alpha the alternative
whose photo is closest to the truth's is kept. Alternatives are relative quantities, as the
truth and every estimate are: scaled so that their mean albedo is the truth's, so glow moved
from the specular lobe into the albedo also makes the whole material darker relative to the
truth, as ``sa-evaluate`` would see it. Photos are torch renders under the sample's own
probe, auto-exposed and encoded as the 8-bit values ``sa-evaluate`` saves (gamma 1/2.2); their
difference is the RMSE in 8-bit levels. Each alternative is then relit under ``sa-evaluate``'s
novel probes with the truth's exposure, and compared with the truth's relighting. The renderer
is linear in the albedo and the specular albedo, so each sample takes three renders (diffuse,
white diffuse, unit specular) per alpha and probe.

An alternative whose photo differs from the truth's by less than ``--levels`` 8-bit levels
(RMSE) cannot be told from the truth by any estimator (the PNG's own rounding is 0.29 levels
RMSE), and one estimate cannot be close to two of them: on one of the two its relit error is
at least half their relit distance (triangle inequality). So per sample the **bound** is half
the largest relit distance between two of the truth and its look-alikes: whatever an estimator
answers for that photo, one of those materials is relit with at least that error. Its mean over
the samples, divided by the naive baseline's mean relit RMSE (``bound_ratio``), is the relit
ratio no estimator can promise to beat when any look-alike may be the truth. The look-alikes
stay within the range of alpha and of mean log relative specular albedo that the test data's own
truths span. The bound is a floor, not an estimate: the search is coarse (a grid of alphas, one
family of albedo changes, the truth's normals) and finds only some of the look-alikes.

A photo shows nothing of the roughness when every alpha of the grid (within the support) has
a look-alike: ``roughness_unseen`` per sample, its share over the test in the summary
(``share_roughness_unseen``). On such a photo an estimator can only answer the roughness its
training data makes likeliest.

Writes ``ambiguity.json`` (per sample and summary) and ``ambiguity.png`` (relit distance
against photo difference, every alternative) into ``--out``; prints the summary as JSON.

    .venv/bin/python scripts/specular_ambiguity.py --materials VAL/plastic \
        --probes PROBES_TRAIN --samples 80 --out OUT
"""

import json
import math
from pathlib import Path

import click
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402

from render.common.atomic_files import atomic_path  # noqa: E402
from render.common.errors import InputError  # noqa: E402
from render.common.exposure import expose  # noqa: E402
from render.common.probes import find_probes, load_probe  # noqa: E402
from render.torch_renderer.renderer import ProbeBank, render  # noqa: E402
from train.data.photos import PHOTO_GAMMA  # noqa: E402
from train.evaluation.estimate_evaluation import (  # noqa: E402
    EvaluationConfig,
    held_out_probes,
    naive_estimate,
    novel_lightings,
    relit_rmse,
    test_samples,
)
from train.training.losses import maps_at_size  # noqa: E402

ALPHAS = (0.02, 0.035, 0.05, 0.075, 0.1, 0.15, 0.2, 0.3, 0.5, 0.75, 1.0)
"""Ward alphas of the alternative lobes (those outside the test data's own range are left out)."""
FACTORS = np.exp(np.linspace(math.log(0.05), math.log(20.0), 121))
"""Factors of the true specular albedo searched for each alternative alpha (those that take
the mean log specular albedo outside the test data's own range are left out)."""


def lobe_renders(truth, bank, probe_index, rotation_deg, alphas):
    """Diffuse renders (P, 3, S, S) of the truth's albedo and of a white albedo with the truth's
    normals, and unit-specular renders {alpha: (P, 3, S, S)} of its normals, under P probes and
    rotations."""
    count = len(probe_index)
    albedo = truth["albedo"].expand(count, -1, -1, -1)
    normal = truth["normal"].expand(count, -1, -1, -1)
    black = torch.zeros(count, 3)
    diffuse, white = (render(a, normal, black, torch.full((count,), 0.1), bank, probe_index,
                             rotation_deg) for a in (albedo, torch.ones_like(albedo)))
    specular = {alpha: render(torch.zeros_like(albedo), normal, torch.ones_like(black),
                              torch.full((count,), alpha), bank,
                              probe_index, rotation_deg) for alpha in alphas}
    return diffuse, white, specular


def as_8bit_levels(hdr):
    """Exposed photos (N, 3, S, S) encoded as the 8-bit values sa-evaluate saves (unrounded)."""
    return 255.0 * expose(hdr).clamp(0, 1) ** (1.0 / PHOTO_GAMMA)


def albedo_fits(target, diffuse, white, specular_parts):
    """Least-squares (scale, offset) per specular part: target - part ~ scale * diffuse +
    offset * white, all (3, S, S) HDR renders under one probe (parts: (F, 3, S, S)); the
    albedo scale * truth + offset renders as scale * diffuse + offset * white. (F, 2)."""
    basis = torch.stack([diffuse.flatten(), white.flatten()], 1).double()  # (N, 2)
    residual = (target[None] - specular_parts).flatten(1).double()  # (F, N)
    # least norm where the albedo is uniform (its render is then the white one, scaled)
    return torch.linalg.lstsq(basis, residual.T, driver="gelsd").solution.T.float()


def sample_alternatives(truth, bank, own_index, novel_index, novel_rotation, support, levels):
    """The truth's HDR renders (own probe first, then the novel ones); per alternative (alpha,
    and whether the albedo may change) the specular factor, the photo difference (8-bit levels
    RMSE) and the relit RMSE against the truth's relighting; and the bound: half the largest
    relit RMSE between two of the truth and the alternatives whose photos differ from its by
    less than ``levels``. ``support``: ((lowest, highest) Ward alpha, (lowest, highest) mean log
    relative specular albedo) the alternatives stay in."""
    log_specular_low, log_specular_high = support[1]
    alphas = grid_alphas(support)
    specular = torch.exp(truth["log_specular"][0])[None, :, None, None]
    true_alpha = float(torch.exp(truth["log_roughness"][0, 0]))
    probes = torch.cat([torch.as_tensor([own_index]), novel_index])
    rotations = torch.cat([torch.zeros(1, dtype=novel_rotation.dtype), novel_rotation])
    diffuse, white, unit = lobe_renders(truth, bank, probes, rotations, alphas + (true_alpha,))
    true_hdr = diffuse + specular * unit[true_alpha]
    true_photo = as_8bit_levels(true_hdr[:1])
    true_relit = expose(true_hdr[1:])
    factors = torch.as_tensor(FACTORS, dtype=torch.float32)
    mean_albedo = float(truth["albedo"].mean())
    lowest_albedo = float(truth["albedo"].min())
    results, look_alike = [], [true_relit]
    for alpha, albedo_free in ((a, free) for a in alphas for free in (False, True)):
        parts = factors[:, None, None, None] * specular * unit[alpha][:1]  # (F, 3, S, S)
        if albedo_free:
            scale, offset = albedo_fits(true_hdr[0], diffuse[0], white[0], parts).unbind(1)
        else:
            scale, offset = torch.ones_like(factors), torch.zeros_like(factors)
        # the alternative's albedo scale * truth + offset and specular albedo factor * truth,
        # both scaled so that its mean albedo is the truth's: relative quantities, as the
        # truth's and an estimate's are (the photo's comparison is blind to that scale)
        renormalize = mean_albedo / (scale * mean_albedo + offset)
        log_specular = (float(truth["log_specular"][0].mean())
                        + torch.log(factors * renormalize.clamp(min=1e-12)))
        valid = ((scale > 0) & (scale * lowest_albedo + offset > 0)
                 & (log_specular >= log_specular_low) & (log_specular <= log_specular_high))
        if not valid.any():
            continue
        candidates = valid.nonzero()[:, 0]
        photos = as_8bit_levels(scale[candidates, None, None, None] * diffuse[:1]
                                + offset[candidates, None, None, None] * white[:1]
                                + parts[candidates])
        photo_rmse = torch.sqrt(((photos - true_photo) ** 2).mean((1, 2, 3)))
        best = int(candidates[torch.argmin(photo_rmse)])
        relit_hdr = renormalize[best] * (scale[best] * diffuse[1:] + offset[best] * white[1:]
                                         + factors[best] * specular * unit[alpha][1:])
        relit = expose(relit_hdr, reference=true_hdr[1:])
        results.append({"alpha": alpha, "albedo_free": albedo_free,
                        "factor": float(factors[best] * renormalize[best]),
                        "albedo_scale": float(scale[best] * renormalize[best]),
                        "albedo_offset": float(offset[best] * renormalize[best]),
                        "photo_levels": float(photo_rmse.min()),
                        "relit_rmse": float(torch.sqrt(torch.mean((relit - true_relit) ** 2)))})
        if results[-1]["photo_levels"] < levels:
            look_alike.append(relit)
    diameter = max(float(torch.sqrt(torch.mean((a - b) ** 2)))
                   for a in look_alike for b in look_alike)
    return true_hdr, results, 0.5 * diameter


def grid_alphas(support):
    """The alphas of ``ALPHAS`` within the support's (lowest, highest) Ward alpha."""
    low, high = support[0]
    return tuple(a for a in ALPHAS if low <= a <= high)


def roughness_unseen(alternatives, alphas, levels):
    """Whether each of ``alphas`` has an alternative (of either kind) whose photo differs from
    the truth's by less than ``levels``: the photo then does not show the roughness."""
    return all(any(a["alpha"] == alpha and a["photo_levels"] < levels for a in alternatives)
               for alpha in alphas)


def write_figure(path, samples, levels):
    """Relit distance over the naive baseline's relit error, against the photo difference, for
    every alternative of every sample (the true albedo kept, or rescaled and offset)."""
    figure, axes = plt.subplots(figsize=(6, 4.5))
    for albedo_free, label in ((False, "true albedo"), (True, "albedo rescaled and offset")):
        chosen = [(a["photo_levels"], a["relit_rmse"] / s["naive_relit_rmse"])
                  for s in samples for a in s["alternatives"] if a["albedo_free"] == albedo_free]
        axes.scatter(*zip(*chosen), s=6, alpha=0.4, label=label)
    axes.axvline(levels, color="k", linestyle="--", linewidth=1,
                 label=f"indistinguishable: < {levels} levels")
    axes.axhline(1.0, color="r", linestyle=":", linewidth=1, label="naive baseline's relit error")
    axes.set_xscale("log")
    axes.set_yscale("log")
    axes.set_xlabel("photo difference to the truth's (8-bit levels, RMSE)")
    axes.set_ylabel("relit distance to the truth / naive relit RMSE")
    axes.set_title("Other specular lobes that photograph alike")
    axes.legend(fontsize=8)
    figure.tight_layout()
    with atomic_path(path) as temporary:
        figure.savefig(temporary, format="png", dpi=120)
    plt.close(figure)


@click.command()
@click.option("--dataset", "datasets", multiple=True, type=click.Path(exists=True),
              help="render-dataset folder (repeatable).")
@click.option("--materials", type=click.Path(exists=True), help="Folder of material folders.")
@click.option("--probes", required=True, type=click.Path(exists=True), help="Folder of probes.")
@click.option("--split", default="test", show_default=True, help="Dataset split, or 'all'.")
@click.option("--samples", default=64, show_default=True)
@click.option("--seed", default=0, show_default=True)
@click.option("--levels", default=1.0, show_default=True,
              help="Photo difference (8-bit levels RMSE) below which two photos count as one.")
@click.option("--out", required=True, type=click.Path(), help="Output folder.")
def main(datasets, materials, probes, split, samples, seed, levels, out):
    cfg = EvaluationConfig(out=out, probes=probes, datasets=tuple(datasets), materials=materials,
                           split=split, samples=samples, seed=seed)
    try:
        summary, records = measure(cfg, levels)
    except (InputError, ValueError) as error:
        raise click.ClickException(str(error)) from None
    with atomic_path(Path(out) / "ambiguity.json") as temporary:
        Path(temporary).write_text(json.dumps({"summary": summary, "samples": records},
                                              indent=1))
    write_figure(Path(out) / "ambiguity.png", records, levels)
    click.echo(json.dumps(summary))


def measure(cfg, levels):
    """(summary, per-sample records) of the test data of ``cfg`` (module docstring)."""
    probe_files = find_probes(cfg.probes)
    names = [path.stem for path in probe_files]
    bank = ProbeBank([load_probe(path).radiance for path in probe_files])
    held_out = held_out_probes(cfg)
    samples = test_samples(cfg, bank, names)
    log_alphas = [float(truth["log_roughness"][0, 0]) for _, truth, _, _ in samples]
    log_speculars = [float(truth["log_specular"][0].mean()) for _, truth, _, _ in samples]
    support = ((math.exp(min(log_alphas)), math.exp(max(log_alphas))),
               (min(log_speculars), max(log_speculars)))
    alphas = grid_alphas(support)
    records = []
    for i, (_, truth, own, name) in enumerate(samples):
        truth = maps_at_size(truth, cfg.sample_size)
        novel_index, novel_rotation = novel_lightings(np.random.default_rng([cfg.seed, 2, i]),
                                                      own, names, held_out, cfg.relights)
        true_hdr, alternatives, bound = sample_alternatives(
            truth, bank, names.index(own), novel_index, novel_rotation, support, levels)
        photo, truth_relit_hdr = expose(true_hdr[:1])[0], true_hdr[1:]
        naive = relit_rmse(naive_estimate(photo), bank, novel_index, novel_rotation,
                           truth_relit_hdr, expose(truth_relit_hdr))
        records.append({"name": name, "probe": own,
                        "true_alpha": float(torch.exp(truth["log_roughness"][0, 0])),
                        "naive_relit_rmse": naive, "alternatives": alternatives,
                        "bound": bound,
                        "roughness_unseen": roughness_unseen(alternatives, alphas, levels)})
        click.echo(f"{i + 1}/{len(samples)} {name}: bound {bound:.4f} naive {naive:.4f}",
                   err=True)
    naive_mean = float(np.mean([r["naive_relit_rmse"] for r in records]))
    bound_mean = float(np.mean([r["bound"] for r in records]))
    summary = {
        "samples": len(records), "levels": levels, "alpha_range": support[0],
        "log_specular_range": support[1], "naive_relit_rmse": naive_mean,
        "bound_relit_rmse": bound_mean, "bound_ratio": bound_mean / naive_mean,
        "share_with_worse_than_naive_twin": float(np.mean([
            any(a["photo_levels"] < levels and a["relit_rmse"] > r["naive_relit_rmse"]
                for a in r["alternatives"]) for r in records])),
        "share_roughness_unseen": float(np.mean([r["roughness_unseen"] for r in records])),
    }
    return summary, records


if __name__ == "__main__":
    main()
