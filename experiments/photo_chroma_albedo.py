"""Try: the estimated albedo takes its colour from the photo, the network only its intensity.

The paper assumes photos are about white balanced: the diffusely reflected colour in the photo
is the diffuse albedo's colour. A network trained on procedural sets still changes the colour
of real ones (the bundled brick photo's white ColorChecker patches come back blue). Here the
network's albedo A (B, 3, S, S) is replaced by mean_c(A) * P / mean_c(P), P the linear photo
(the per-pixel chromaticity of the photo, its channel mean 1; a pixel darker than EPSILON keeps
the network's colour). Measured with scripts/real_validation.py's folds, probes and photos, as
the choice ``<class>+photo-chroma`` beside the plain networks.

    .venv/bin/python experiments/photo_chroma_albedo.py --out OUT [--classes general,auto]
"""

import sys
from pathlib import Path

import click
import torch
from torch import nn

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "scripts"))
from real_validation import (FOLDS, SHARED, SHIPPED_TRAINING_SETS,  # noqa: E402
                             VALIDATION_PROBES, linked_folder, summarize)

from train.estimation.network_choice import network_choice  # noqa: E402
from train.evaluation.estimate_evaluation import EvaluationConfig, run  # noqa: E402

EPSILON = 1e-4


class PhotoChroma(nn.Module):
    """A network whose albedo is re-coloured with the photo's chromaticity."""

    def __init__(self, net):
        super().__init__()
        self.net, self.config, self.source = net, net.config, net.source

    def forward(self, image):
        outputs = self.net(image)
        photo_mean = image.mean(1, keepdim=True)
        chroma = torch.where(photo_mean > EPSILON, image / photo_mean.clamp(min=EPSILON),
                             torch.ones_like(image))
        outputs["albedo"] = outputs["albedo"].mean(1, keepdim=True) * chroma
        return outputs


class Recoloured:
    """A network choice (train.estimation.network_choice) whose networks are PhotoChroma."""

    def __init__(self, choice):
        self.choice, self.input_size = choice, choice.input_size

    def for_photo(self, photo):
        net, chosen = self.choice.for_photo(photo)
        return PhotoChroma(net), chosen


@click.command()
@click.option("--out", required=True, type=click.Path())
@click.option("--classes", default="general,auto", show_default=True)
@click.option("--samples", default=60, show_default=True)
@click.option("--relights", default=3, show_default=True)
def main(out, classes, samples, relights):
    out = Path(out)
    probes = linked_folder(out / "probes-validation",
                           [f"{n}.exr" for n in VALIDATION_PROBES], SHARED / "probes")
    names = []
    for material_class in classes.split(","):
        name = f"{material_class}+photo-chroma"
        names.append(name)
        for fold, sets in FOLDS.items():
            kept = [s for s in sets if s not in SHIPPED_TRAINING_SETS]
            folder = linked_folder(out / "sets" / fold, kept, SHARED / "svbrdfs")
            if (out / fold / name / "results.json").is_file():
                continue
            run(EvaluationConfig(out=str(out / fold / name), probes=str(probes),
                                 materials=str(folder), samples=samples, relights=relights),
                Recoloured(network_choice(None, material_class)))
    plain = [c for c in ("general", "wood", "plastic", "metal", "auto")
             if (out / "fold1" / c / "results.json").is_file()]
    summarize(out, list(FOLDS), plain + names)
    click.echo((out / "table.md").read_text())


if __name__ == "__main__":
    main()
