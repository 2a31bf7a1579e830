"""Try: per-photo policies for the specular lobe, measured on the real-set validation in seconds.

On the real-set validation (scripts/real_validation.py) the truth's specular albedo and
roughness swapped into plastic's estimate take its relit error to about 0.51x the naive
baseline's, and 41% of the baseline's relit error is on five metals, where the plastic network
relights no better than the baseline (24 sets, 2026-12-05). This caches, once per fold, what
sa-evaluate sees of each validation photo (the photo read back from its 8-bit file, the
truth, the relight probes and rotations, the plastic and metal networks' estimates: the same
photos and draws as sa-evaluate's, so the plain policies reproduce its figures) and then
measures policies that combine them without running a network again:

    plastic, metal          the shipped networks' estimates
    unknown                 the default estimate (sa-estimate --class unknown): plastic's
                            maps with the naive lobe
    plastic+lobe<w>         plastic's log specular and log roughness blended with the naive
                            lobe's: w times its own plus (1 - w) times the baseline's (w = 0
                            is unknown, w = 1 plastic)
    metal-if-flat<t>        the metal network's estimate for photos whose luminance varies
                            less than t (standard deviation over mean of the linear photo),
                            the plastic network's for the others
    plastic+fixed-lobe-if-unsure<t>
                            the naive lobe in plastic's estimate for photos whose lobe the
                            plastic network reads differently across the photo's 8 dihedral
                            views (rotations by 90 degrees, mirrorings: the same material
                            under rotated or mirrored light) by more than t (the root mean
                            square over its 3 log specular albedos and log roughness of their
                            standard deviation across the views); its own lobe for the others
    plastic+lobe=<s>,<a>    plastic's maps with a constant lobe: relative specular albedo s on
                            every channel, Ward alpha a (CONSTANT_LOBES; the naive lobe is
                            0.08, 0.25)
    unknown+photo-normals<k>
                            the default estimate (plastic's albedo, the naive lobe) with
                            normals from the photo's shading: a height of k times the log of
                            its luminance, in pixels (darker lower for k > 0)
    unknown+photo-relief<k>,<b>
                            photo-normals<k> with the shading they stand for taken out of
                            plastic's albedo: divided by exp(b (log L - mean log L)), L the
                            photo's luminance, and scaled back to its mean (b = 0 is
                            photo-normals<k>; the truth's albedo and normals together relight
                            at 0.76x, each alone at 0.88x and 0.91x)
    unknown+normal-gain<g>  the default estimate with plastic's normals' slopes (x/z, y/z)
                            times g: the relief it reads, g times as deep
    unknown+albedo<w>       the default estimate with w times plastic's albedo plus 1 - w
                            times the naive one (the photo scaled to mean 0.5)
    plastic+true-lobe       the truth's lobe in plastic's estimate (the ceiling of a reader)
    unknown+flat            the default estimate with flat normals
    unknown+share=<c>       no network: the albedo the photo-affine albedo network would give
                            with a constant reflection share c (photo_affine_albedo), flat
                            normals, the naive lobe
    unknown+share-specular<k>
                            the default estimate with the relative specular albedo the share
                            s that plastic's photo-affine network reads implies, k s / (2 (1 -
                            s)) on every channel (under uniform light a photo's mean is
                            mean(albedo) + specular, so a share s of it is specular when the
                            relative specular is s / (2 (1 - s))), Ward alpha 0.25

With the share policies measured, OUT/share.png plots the share plastic's network reads of each
photo against the truth's relative specular albedo, and each set's relit ratio under the default
and under the best constant share.

A policy's parameter is chosen the way every choice is: on the validation, and its cross-
validated figure chooses it on three folds and measures it on the fourth. Writes OUT/cache/
<fold>.pt (tensors only; read with weights_only) and OUT/policies.json, and prints the table.
``--only PREFIX`` measures the policies whose names start with it (and the naive baseline,
plastic and unknown, beside them).

    .venv/bin/python experiments/lobe_policies.py --out OUT [--only PREFIX]
"""

import json
import math
import sys
import tempfile
from pathlib import Path

import click
import numpy as np
import torch
from matplotlib.figure import Figure

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "scripts"))
from real_validation import (  # noqa: E402
    FOLDS,
    SHARED,
    linked_folder,
    material_set,
    split_probe_folder,
)

from render.common.atomic_files import atomic_path  # noqa: E402
from render.common.exposure import expose  # noqa: E402
from render.common.probes import find_probes, load_probe  # noqa: E402
from render.torch_renderer.renderer import ProbeBank  # noqa: E402
from train.data.photos import read_photo  # noqa: E402
from train.estimation.network_choice import (  # noqa: E402
    FIXED_ROUGHNESS,
    FIXED_SPECULAR,
    network_choice,
)
from train.evaluation.estimate_evaluation import (  # noqa: E402
    EvaluationConfig,
    as_photo_file,
    maps_at_size,
    model_estimate,
    naive_estimate,
    novel_lightings,
    relit_rmse,
    relit_under,
    test_samples,
)
from train.networks.svbrdf_net import photo_affine_albedo  # noqa: E402

NETWORKS = ("plastic", "metal")
BLEND_WEIGHTS = (0.0, 0.25, 0.5, 0.75, 1.0)
FLATNESS_THRESHOLDS = (0.0, 0.02, 0.03, 0.04, 0.05, 0.06, 0.07, 0.08, 0.1)
SPREAD_THRESHOLDS = (0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.6)
PHOTO_NORMAL_STRENGTHS = (-2.0, -1.0, -0.5, 0.5, 1.0, 2.0)
ALBEDO_WEIGHTS = (0.0, 0.5, 0.75, 1.25, 1.5)
RELIEF_STRENGTHS = (0.5, 1.0, 2.0)
NORMAL_GAINS = (1.5, 2.0, 4.0, 8.0)
SHADING_SHARES = (0.25, 0.5, 1.0)
REFLECTION_SHARES = (0.05, 0.1, 0.15, 0.2, 0.3, 0.4)
SHARE_SPECULAR_GAINS = (0.25, 0.5, 1.0, 2.0, 4.0)
CONSTANT_LOBES = tuple((specular, alpha) for specular in (0.04, 0.06, 0.08, 0.12, 0.16)
                       for alpha in (0.15, 0.25, 0.4))


def dihedral_views(photo: np.ndarray) -> list[np.ndarray]:
    """The 8 rotations by multiples of 90 degrees of a (3, S, S) photo and of its mirror."""
    mirrored = photo[:, :, ::-1]
    return [np.ascontiguousarray(np.rot90(image, k, axes=(1, 2)))
            for image in (photo, mirrored) for k in range(4)]


def photo_normals(photo: torch.Tensor, strength: float) -> torch.Tensor:
    """(1, 3, S, S) unit normals (OpenGL: x right, y up the image) of the height field
    ``strength`` * log luminance of a (3, S, S) linear photo, in pixels; central differences,
    wrapped at the borders."""
    height = strength * torch.log(photo.mean(0) + 1e-3)
    d_right = (torch.roll(height, -1, 1) - torch.roll(height, 1, 1)) / 2.0
    d_down = (torch.roll(height, -1, 0) - torch.roll(height, 1, 0)) / 2.0
    normal = torch.stack([-d_right, d_down, torch.ones_like(height)])
    return (normal / normal.norm(dim=0, keepdim=True))[None]


def deeper_relief(normal: torch.Tensor, gain: float) -> torch.Tensor:
    """(1, 3, S, S) unit normals with the slopes (x/z, y/z) of ``normal`` times ``gain``."""
    steeper = torch.cat([normal[:, :2] * gain, normal[:, 2:]], 1)
    return steeper / steeper.norm(dim=1, keepdim=True)


def without_shading(albedo: torch.Tensor, photo: torch.Tensor, share: float) -> torch.Tensor:
    """(1, 3, S, S) ``albedo`` divided by exp(share (log L - mean log L)), L the (3, S, S) linear
    photo's channel mean, then scaled back to its own mean."""
    log_luminance = torch.log(photo.mean(0) + 1e-3)
    divided = albedo * torch.exp(-share * (log_luminance - log_luminance.mean()))
    return divided * (albedo.mean() / divided.mean().clamp_min(1e-6))


def reflection_share(choice, photo: np.ndarray) -> float:
    """The share of a (3, S, S) photo's mean that ``choice``'s photo-affine albedo network
    reads as reflection (train.networks.svbrdf_net.PhotoAffineAlbedoNet)."""
    with torch.no_grad():
        logit = choice.net.albedo.affine(torch.as_tensor(photo)[None])
    return float(torch.sigmoid(logit))


def share_albedo(photo: torch.Tensor, share: float) -> torch.Tensor:
    """(1, 3, S, S) relative albedo of a (3, S, S) linear photo less a grey offset of
    ``share`` of its mean, as the photo-affine albedo network makes it."""
    logit = torch.full((1, 1), math.log(share / (1.0 - share)))
    return photo_affine_albedo(logit, photo[None].float())


def lobe_spread(choice, photo: np.ndarray) -> float:
    """How differently ``choice`` reads the lobe across the photo's dihedral views (module
    docstring: plastic+fixed-lobe-if-unsure)."""
    lobes = []
    for view in dihedral_views(photo):
        estimate = model_estimate(choice, view)[0]
        lobes.append(torch.cat([estimate["log_specular"][0], estimate["log_roughness"][0]]))
    return float(torch.stack(lobes).std(0).pow(2).mean().sqrt())


def luminance_variation(photo: torch.Tensor) -> float:
    """Standard deviation over mean of a (3, S, S) linear photo's channel mean."""
    grey = photo.mean(0)
    return float(grey.std() / grey.mean().clamp_min(1e-6))


def cache_fold(out: Path, fold: str, samples: int, relights: int) -> list[dict]:
    """What sa-evaluate sees of the fold's photos (module docstring), cached in OUT/cache."""
    path = out / "cache" / f"{fold}.pt"
    if path.is_file():
        rows = torch.load(path, weights_only=True)
        if all("plastic_share" in row for row in rows):  # else a cache older than the share's
            return rows
    kept = list(FOLDS[fold])
    cfg = EvaluationConfig(out=str(out / fold), probes=str(split_probe_folder(out, "validation")),
                           materials=str(linked_folder(out / "sets" / fold, kept,
                                                       SHARED / "svbrdfs")),
                           samples=samples, relights=relights)
    bank, names = probe_bank(out)
    choices = {name: network_choice(None, name) for name in NETWORKS}
    size = choices["plastic"].input_size
    rows = []
    with tempfile.TemporaryDirectory() as photos:
        for i, (image, truth, own_probe, name) in enumerate(test_samples(cfg, bank, names)):
            photo = read_photo(as_photo_file(image, photos, f"{i:05d}"), size)
            probe_index, rotation = novel_lightings(np.random.default_rng([cfg.seed, 2, i]),
                                                    own_probe, names, set(), relights)
            row = {"set": material_set(name), "photo": torch.as_tensor(photo),
                   "probe_index": probe_index, "rotation": rotation,
                   "truth": maps_at_size(truth, size), "naive": naive_estimate(photo)}
            for network in NETWORKS:
                row[network] = model_estimate(choices[network], photo)[0]
            row["plastic_lobe_spread"] = lobe_spread(choices["plastic"], photo)
            row["plastic_share"] = reflection_share(choices["plastic"], photo)
            rows.append(row)
            print(f"{fold}: {i + 1} of {samples} photos", flush=True)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        torch.save(rows, tmp)
    return rows


def probe_bank(out: Path) -> tuple[ProbeBank, list[str]]:
    """The validation probes as a ProbeBank, and their names in its order."""
    files = find_probes(split_probe_folder(out, "validation"))
    return ProbeBank([load_probe(p).radiance for p in files]), [p.stem for p in files]


def with_lobe(estimate: dict, weight: float, specular: float = FIXED_SPECULAR,
              alpha: float = FIXED_ROUGHNESS) -> dict:
    """``estimate`` with its log lobe blended with a constant lobe's, by default the naive
    lobe (module docstring)."""
    fixed = {"log_specular": math.log(specular), "log_roughness": math.log(alpha)}
    return estimate | {name: weight * estimate[name] + (1.0 - weight) * value
                       for name, value in fixed.items()}


def policies(row: dict) -> dict[str, dict]:
    """Every policy's estimate of one cached photo: {policy name: parameters}."""
    chosen = {"naive": row["naive"], "plastic": row["plastic"], "metal": row["metal"],
              "plastic+true-lobe": row["plastic"] | {name: row["truth"][name] for name in
                                                     ("log_specular", "log_roughness")}}
    for weight in BLEND_WEIGHTS[1:-1]:
        chosen[f"plastic+lobe{weight:g}"] = with_lobe(row["plastic"], weight)
    unknown = with_lobe(row["plastic"], 0.0)
    chosen["unknown"] = unknown
    for strength in PHOTO_NORMAL_STRENGTHS:
        chosen[f"unknown+photo-normals{strength:g}"] = unknown | {
            "normal": photo_normals(row["photo"], strength)}
    for strength in RELIEF_STRENGTHS:
        for share in SHADING_SHARES:
            chosen[f"unknown+photo-relief{strength:g},{share:g}"] = unknown | {
                "normal": photo_normals(row["photo"], strength),
                "albedo": without_shading(unknown["albedo"], row["photo"], share)}
    for gain in NORMAL_GAINS:
        chosen[f"unknown+normal-gain{gain:g}"] = unknown | {
            "normal": deeper_relief(unknown["normal"], gain)}
    for weight in ALBEDO_WEIGHTS:
        chosen[f"unknown+albedo{weight:g}"] = unknown | {
            "albedo": weight * unknown["albedo"] + (1.0 - weight) * row["naive"]["albedo"]}
    flat = row["naive"]["normal"]
    chosen["unknown+flat"] = unknown | {"normal": flat}
    for share in REFLECTION_SHARES:
        chosen[f"unknown+share={share:g}"] = unknown | {
            "albedo": share_albedo(row["photo"], share), "normal": flat}
    share = row["plastic_share"]
    for gain in SHARE_SPECULAR_GAINS:
        specular = min(max(gain * share / (2.0 * (1.0 - share)), 1e-3), 50.0)
        chosen[f"unknown+share-specular{gain:g}"] = with_lobe(row["plastic"], 0.0, specular)
    for specular, alpha in CONSTANT_LOBES:
        chosen[f"plastic+lobe={specular:g},{alpha:g}"] = with_lobe(row["plastic"], 0.0, specular,
                                                                    alpha)
    for threshold in SPREAD_THRESHOLDS:
        unsure = row["plastic_lobe_spread"] > threshold
        chosen[f"plastic+fixed-lobe-if-unsure{threshold:g}"] = (
            with_lobe(row["plastic"], 0.0) if unsure else row["plastic"])
    flatness = luminance_variation(row["photo"])
    for threshold in FLATNESS_THRESHOLDS[1:]:
        chosen[f"metal-if-flat{threshold:g}"] = row["metal" if flatness < threshold else "plastic"]
    return chosen


def relit_errors(out: Path, folds: dict[str, list[dict]],
                 only: str = "") -> dict[str, dict[str, list]]:
    """{fold: {policy: [relit RMSE per photo]}, "sets": [set per photo]} of every policy
    whose name starts with ``only``, and of the naive baseline, plastic and unknown."""
    bank, _ = probe_bank(out)
    errors = {}
    for fold, rows in folds.items():
        errors[fold] = {"sets": [row["set"] for row in rows]}
        for row in rows:
            truth_hdr = relit_under(row["truth"], bank, row["probe_index"], row["rotation"])
            relit_truth = expose(truth_hdr)
            for name, parameters in policies(row).items():
                if not name.startswith(only) and name not in ("naive", "plastic", "unknown"):
                    continue
                errors[fold].setdefault(name, []).append(relit_rmse(
                    parameters, bank, row["probe_index"], row["rotation"], truth_hdr,
                    relit_truth))
    return errors


def ratio(errors: dict, folds: list[str], policy: str) -> float:
    """The policy's relit RMSE over the naive baseline's (ratio of sums) on ``folds``."""
    return (sum(sum(errors[f][policy]) for f in folds)
            / sum(sum(errors[f]["naive"]) for f in folds))


def cross_validated(errors: dict, family: list[str]) -> tuple[float, dict[str, str]]:
    """Each fold's figure with the member of ``family`` best on the other three: (the ratio
    over every fold, {fold: the member chosen for it})."""
    picks = {fold: min(family, key=lambda p: ratio(errors, [f for f in errors if f != fold], p))
             for fold in errors}
    model = sum(sum(errors[f][picks[f]]) for f in errors)
    return model / sum(sum(errors[f]["naive"]) for f in errors), picks


def worst_set(errors: dict, policy: str) -> tuple[str, float]:
    """The set whose relit ratio is highest under ``policy``."""
    ratios = set_ratios(errors, policy)
    name = max(ratios, key=ratios.get)
    return name, ratios[name]


def set_ratios(errors: dict, policy: str) -> dict[str, float]:
    """{set: its relit ratio (sum over its photos, model over naive) under ``policy``}."""
    sums = {}
    for fold in errors:
        for name, model, naive in zip(errors[fold]["sets"], errors[fold][policy],
                                      errors[fold]["naive"]):
            total = sums.setdefault(name, [0.0, 0.0])
            total[0] += model
            total[1] += naive
    return {name: model / naive for name, (model, naive) in sums.items()}


def share_figure(folds: dict[str, list[dict]], errors: dict, best_share: str,
                 path: Path) -> None:
    """OUT/share.png (module docstring): left, per photo, the reflection share plastic's
    network reads against the truth's relative specular albedo (channel mean; metals, whose
    truth's specular is above 1, stand apart); right, each set's relit ratio under the default
    and under ``best_share`` (a unknown+share=<c> policy)."""
    rows = [row for fold in folds.values() for row in fold]
    figure = Figure(figsize=(13.0, 4.8))
    left, right = figure.subplots(1, 2, gridspec_kw={"width_ratios": [1, 2]})
    truth = [float(row["truth"]["log_specular"].exp().mean()) for row in rows]
    left.scatter(truth, [row["plastic_share"] for row in rows], s=10)
    left.set_xscale("log")
    left.set_xlabel("truth's relative specular albedo")
    left.set_ylabel("reflection share plastic's network reads")
    default, constant = set_ratios(errors, "unknown"), set_ratios(errors, best_share)
    names = sorted(default)
    positions = np.arange(len(names))
    right.bar(positions - 0.2, [default[n] for n in names], 0.4, label="unknown (the default)")
    right.bar(positions + 0.2, [constant[n] for n in names], 0.4, label=best_share)
    right.axhline(1.0, color="black", linewidth=0.8)
    right.set_xticks(positions, names, rotation=75, ha="right", fontsize=7)
    right.set_ylabel("relit RMSE / naive")
    right.legend(fontsize=8, loc="lower left")
    figure.tight_layout()
    with atomic_path(path) as tmp:
        figure.savefig(tmp, format="png", dpi=100)


@click.command()
@click.option("--out", required=True, type=click.Path())
@click.option("--samples", default=60, show_default=True, help="Photos per fold.")
@click.option("--relights", default=3, show_default=True)
@click.option("--only", default="", help="Measure the policies whose names start with this.")
def main(out, samples, relights, only):
    out = Path(out)
    folds = {fold: cache_fold(out, fold, samples, relights) for fold in FOLDS}
    errors = relit_errors(out, folds, only)
    every = list(errors)
    table = {}
    for policy in errors["fold1"]:
        if policy == "sets":
            continue
        name, worst = worst_set(errors, policy)
        table[policy] = {"relit_ratio": ratio(errors, every, policy),
                         "per_fold": [ratio(errors, [f], policy) for f in every],
                         "worst_set": name, "worst_relit_ratio": worst}
    families = {"plastic+lobe<w>": ["unknown"] + [f"plastic+lobe{w:g}" for w in BLEND_WEIGHTS[1:-1]]
                + ["plastic"],
                "metal-if-flat<t>": ["plastic"] + [f"metal-if-flat{t:g}"
                                                   for t in FLATNESS_THRESHOLDS[1:]],
                "plastic+fixed-lobe-if-unsure<t>": ["plastic"] + [
                    f"plastic+fixed-lobe-if-unsure{t:g}" for t in SPREAD_THRESHOLDS],
                "plastic+lobe=<s>,<a>": [f"plastic+lobe={s:g},{a:g}" for s, a in CONSTANT_LOBES],
                "unknown+photo-normals<k>": ["unknown"] + [
                    f"unknown+photo-normals{k:g}" for k in PHOTO_NORMAL_STRENGTHS],
                "unknown+photo-relief<k>,<b>": ["unknown"] + [
                    f"unknown+photo-relief{k:g},{b:g}" for k in RELIEF_STRENGTHS
                    for b in SHADING_SHARES],
                "unknown+normal-gain<g>": ["unknown"] + [
                    f"unknown+normal-gain{g:g}" for g in NORMAL_GAINS],
                "unknown+albedo<w>": ["unknown"] + [f"unknown+albedo{w:g}"
                                                   for w in ALBEDO_WEIGHTS],
                "unknown+share=<c>": [f"unknown+share={c:g}" for c in REFLECTION_SHARES],
                "unknown+share-specular<k>": ["unknown"] + [
                    f"unknown+share-specular{k:g}" for k in SHARE_SPECULAR_GAINS]}
    families = {family: members for family, members in families.items()
                if all(member in errors["fold1"] for member in members)}
    if "unknown+share=<c>" in families:
        best = min(families["unknown+share=<c>"], key=lambda p: table[p]["relit_ratio"])
        share_figure(folds, errors, best, out / "share.png")
    for family, members in families.items():
        value, picks = cross_validated(errors, members)
        table[f"{family}, cross-validated"] = {"relit_ratio": value, "picks": picks}
    with atomic_path(out / "policies.json") as tmp:
        tmp.write_text(json.dumps({"table": table, "errors": errors}, indent=1))
    click.echo("| policy | relit / naive | per fold | worst set (relit) |")
    click.echo("| --- | --- | --- | --- |")
    for policy, row in table.items():
        folds_text = ", ".join(f"{v:.2f}" for v in row.get("per_fold", []))
        worst = (f"{row['worst_set']} ({row['worst_relit_ratio']:.2f})" if "worst_set" in row
                 else ", ".join(f"{f}: {p}" for f, p in row["picks"].items()))
        click.echo(f"| {policy} | {row['relit_ratio']:.3f} | {folds_text} | {worst} |")


if __name__ == "__main__":
    main()
