"""Measurement: how much of the default estimate's and the naive baseline's relit error on the
real-set validation is the albedo's colour cast, and how much its pattern.

The relative albedo of an estimate has one overall scale (mean 0.5 over pixels and channels), so
its three channel gains carry the lighting's colour the photo was taken under. Here each
estimate's albedo A (3, S, S) is refit by oracle gains against the truth T, least squares:
``scalar``: one gain g for all channels (g A), ``channel``: a gain per channel (g_c A_c, the
oracle white balance). The relit RMSE of the estimate with each refit albedo (lobe and normals
unchanged), over the relit RMSE of the naive baseline as it is, says what a perfect white
balance, or a perfect exposure, would gain; ``true_maps`` is the naive lobe with the
truth's albedo and normals (what maps alone could reach under the fixed lobe). The photos, their
truth, relight draws and plastic's estimates are experiments/lobe_policies.py's cache in OUT
(made there when missing): the real validation's 240 photos. Writes OUT/albedo_sources.json and
prints the ratios of means per fold and over all.

    .venv/bin/python experiments/albedo_error_sources.py --out OUT [--samples 60]
"""

import json
import sys
from pathlib import Path

import click
import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parent))
from lobe_policies import FOLDS, cache_fold, probe_bank, with_lobe  # noqa: E402

from render.common.exposure import expose  # noqa: E402
from train.evaluation.estimate_evaluation import relit_rmse, relit_under  # noqa: E402

REFITS = ("as_is", "scalar", "channel")


def refit_albedo(albedo: torch.Tensor, truth: torch.Tensor, refit: str) -> torch.Tensor:
    """``albedo`` (1, 3, S, S) times the least-squares gains against ``truth``: none
    (``as_is``), one for all channels (``scalar``) or one per channel (``channel``)."""
    if refit == "as_is":
        return albedo
    dims = (0, 1, 2, 3) if refit == "scalar" else (0, 2, 3)
    gain = (albedo * truth).sum(dims, keepdim=True) / (albedo * albedo).sum(
        dims, keepdim=True).clamp(min=1e-12)
    return albedo * gain


@click.command()
@click.option("--out", required=True, type=click.Path())
@click.option("--samples", default=60, show_default=True)
@click.option("--relights", default=3, show_default=True)
def main(out, samples, relights):
    out = Path(out)
    bank, _ = probe_bank(out)
    rows = []
    for fold in FOLDS:
        for photo in cache_fold(out, fold, samples, relights):
            truth, lighting = photo["truth"], (photo["probe_index"], photo["rotation"])
            truth_hdr = relit_under(truth, bank, *lighting)
            relit_truth = expose(truth_hdr)
            row = {"fold": fold, "set": photo["set"]}
            for kind, estimate in (("model", with_lobe(photo["plastic"], 0.0)),
                                   ("naive", photo["naive"])):
                for refit in REFITS:
                    albedo = refit_albedo(estimate["albedo"], truth["albedo"], refit)
                    row[f"{kind}_{refit}_relit"] = relit_rmse(
                        estimate | {"albedo": albedo}, bank, *lighting, truth_hdr, relit_truth)
                    row[f"{kind}_{refit}_albedo"] = float(torch.sqrt(torch.mean(
                        (albedo - truth["albedo"]) ** 2)))
            true_maps = {"albedo": truth["albedo"], "normal": truth["normal"]}
            row["true_maps_relit"] = relit_rmse(photo["naive"] | true_maps, bank, *lighting,
                                                truth_hdr, relit_truth)
            rows.append(row)
    (out / "albedo_sources.json").write_text(json.dumps(rows, indent=1))
    for fold in (*FOLDS, "all"):
        kept = [row for row in rows if fold in ("all", row["fold"])]
        naive = np.mean([row["naive_as_is_relit"] for row in kept])
        naive_albedo = np.mean([row["naive_as_is_albedo"] for row in kept])
        print(fold, {f"{kind}_{refit}": (round(np.mean([r[f"{kind}_{refit}_relit"]
                                                         for r in kept]) / naive, 3),
                                          round(np.mean([r[f"{kind}_{refit}_albedo"]
                                                         for r in kept]) / naive_albedo, 3))
                     for kind in ("model", "naive") for refit in REFITS},
              "true maps, fixed lobe", round(np.mean([r["true_maps_relit"]
                                                      for r in kept]) / naive, 3))


if __name__ == "__main__":
    main()
