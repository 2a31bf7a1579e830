"""Try: the estimated albedo takes its colour from the photo, the network only its intensity.

The paper assumes photos are about white balanced: the diffusely reflected colour in the photo
is the diffuse albedo's colour. A network trained on procedural sets still changes the colour
of real ones (the bundled brick photo's white ColorChecker patches come back blue). Here the
network's albedo A (B, 3, S, S) is replaced by mean_c(A) * P / mean_c(P), P the linear photo
(the per-pixel chromaticity of the photo, its channel mean 1; a pixel darker than EPSILON keeps
the network's colour). Measured with scripts/real_validation.py's folds, probes and photos, as
the choice ``<class>+photo-chroma`` beside the plain networks.

    .venv/bin/python experiments/photo_chroma_albedo.py --out OUT [--classes plastic]
"""

import sys
from pathlib import Path

import click
import torch
from torch import nn

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "scripts"))
from real_validation import evaluate_choice, report_beside_shipped  # noqa: E402

from train.estimation.network_choice import network_choice  # noqa: E402

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
        self.model_files, self.fixed_lobe = choice.model_files, choice.fixed_lobe

    def for_photo(self, photo):
        net, chosen = self.choice.for_photo(photo)
        return PhotoChroma(net), chosen


@click.command()
@click.option("--out", required=True, type=click.Path())
@click.option("--classes", default="plastic", show_default=True)
@click.option("--samples", default=60, show_default=True)
@click.option("--relights", default=3, show_default=True)
def main(out, classes, samples, relights):
    out = Path(out)
    names = []
    for material_class in classes.split(","):
        names.append(f"{material_class}+photo-chroma")
        evaluate_choice(out, "validation", names[-1],
                        lambda fold, c=material_class: Recoloured(network_choice(None, c)),
                        samples, relights)
    report_beside_shipped(out, names)


if __name__ == "__main__":
    main()
