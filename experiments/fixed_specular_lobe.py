"""Try: a network's albedo and normals with a fixed specular lobe in place of its own reading.

On the real-set validation (scripts/real_validation.py) the relit error is mostly the specular
lobe's: the truth's specular albedo and roughness swapped into an estimate take it to about 0.41x
the baseline, whichever the estimate. This measures whether the networks' readings of the lobe
beat a fixed guess there: the network's log specular and log roughness are replaced by
``weight`` times their own plus (1 - weight) times the naive baseline's (relative specular 0.08,
alpha 0.25); weight 0 is the fixed lobe, 1 the network's own. Results go beside the plain
networks' as the choice ``<class>+lobe<weight>``.

    .venv/bin/python experiments/fixed_specular_lobe.py --out OUT [--classes plastic] \
        [--weights 0,0.5]
"""

import math
import sys
from pathlib import Path

import click
import torch
from torch import nn

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "scripts"))
from real_validation import evaluate_choice, report_beside_shipped  # noqa: E402

from train.estimation.network_choice import (  # noqa: E402
    FIXED_ROUGHNESS,
    FIXED_SPECULAR,
    network_choice,
)


class BlendedLobe(nn.Module):
    """A network whose log specular and log roughness are blended with the naive lobe's."""

    def __init__(self, net, weight):
        super().__init__()
        self.net, self.weight, self.config, self.source = net, weight, net.config, net.source

    def forward(self, image):
        outputs = self.net(image)
        for name, fixed in (("log_specular", math.log(FIXED_SPECULAR)),
                            ("log_roughness", math.log(FIXED_ROUGHNESS))):
            outputs[name] = self.weight * outputs[name] + (1.0 - self.weight) * torch.full_like(
                outputs[name], fixed)
        return outputs


class Blended:
    """A network choice (train.estimation.network_choice) whose networks are BlendedLobe."""

    def __init__(self, choice, weight):
        self.choice, self.weight, self.input_size = choice, weight, choice.input_size
        self.model_files, self.fixed_lobe = choice.model_files, choice.fixed_lobe

    def for_photo(self, photo):
        net, chosen = self.choice.for_photo(photo)
        return BlendedLobe(net, self.weight), chosen


@click.command()
@click.option("--out", required=True, type=click.Path())
@click.option("--classes", default="plastic", show_default=True)
@click.option("--weights", default="0,0.5", show_default=True)
@click.option("--samples", default=60, show_default=True)
@click.option("--relights", default=3, show_default=True)
def main(out, classes, weights, samples, relights):
    out = Path(out)
    names = []
    for material_class in classes.split(","):
        for weight in (float(w) for w in weights.split(",")):
            names.append(f"{material_class}+lobe{weight:g}")
            evaluate_choice(out, "validation", names[-1],
                            lambda fold, c=material_class, w=weight: Blended(
                                network_choice(None, c), w), samples, relights)
    report_beside_shipped(out, names)


if __name__ == "__main__":
    main()
