"""Command line of ``sa-train``: parse options, build a TrainConfig, call run(cfg)."""

import dataclasses
import json
import logging
import os
import signal
from typing import Any

import click

from render.common.errors import InputError
from train.networks.svbrdf_net import (
    ALBEDO_NETWORKS,
    COMPACT_CONFIG,
    HOMOGENEOUS_POOLINGS,
    PARTS,
    SMALL_CPU_CONFIG,
    NetworkConfig,
)
from train.training.interruption import TrainingStopped
from train.training.losses import ALBEDO_LOSSES, RELIT_LOSS_FORMS
from train.training.optimization import OptimizerConfig
from train.training.trainer import RELIT_PARTNERS, TrainConfig, run

NETWORKS = {"paper": NetworkConfig(), "compact": COMPACT_CONFIG, "small": SMALL_CPU_CONFIG}


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--dataset", type=click.Path(), default=None,
              help="render-dataset output (its test split evaluates; its train split trains "
                   "unless --labeled-maps is given).")
@click.option("--labeled-maps", type=click.Path(), default=None,
              help="Material folders: labeled minibatches rendered on the fly (torch renderer).")
@click.option("--render-size", default=512, show_default=True,
              help="With --labeled-maps: shorter side the maps are resampled to before cropping.")
@click.option("--crop-scales", default="1", show_default=True,
              help="With --labeled-maps: comma-separated whole numbers; a crop spans the input "
                   "size times one of them, box filtered down (1,2: textures at their scale "
                   "and at half of it).")
@click.option("--mix-specular/--own-specular", default=False, show_default=True,
              help="With --labeled-maps: give each sample the specular albedo and roughness "
                   "of a random material of the folder (not only its own texture's).")
@click.option("--epoch-samples", default=3200, show_default=True,
              help="With --labeled-maps: labeled samples per epoch.")
@click.option("--init-from", type=click.Path(), default=None,
              help="Start from this model's weights (fine-tuning); same network configuration.")
@click.option("--train-networks", default=",".join(PARTS), show_default=True,
              help="Comma-separated networks to train; the others keep their --init-from "
                   "weights.")
@click.option("--out", required=True, type=click.Path(), help="Run folder.")
@click.option("--probes", required=True, type=click.Path(),
              help="HDR probes for self-augmentation renders and relit evaluation.")
@click.option("--unlabeled", type=click.Path(), default=None,
              help="Unlabeled photos (or a dataset folder); without it: the baseline.")
@click.option("--network", "network_name", type=click.Choice(sorted(NETWORKS)), default="paper",
              show_default=True, help="Network size preset (compact: the shipped models; "
                                      "small: trains on a CPU).")
@click.option("--input-size", type=int, default=None, help="Override the preset's input size.")
@click.option("--width", type=int, default=None, help="Override the preset's first width.")
@click.option("--levels", type=int, default=None, help="Override the preset's levels.")
@click.option("--homogeneous-pooling", type=click.Choice(HOMOGENEOUS_POOLINGS), default=None,
              help="Override the preset's: how the homogeneous network reads its bottleneck "
                   "(flatten, the paper's; mean, averaged over positions).")
@click.option("--albedo-network", type=click.Choice(ALBEDO_NETWORKS), default=None,
              help="Override the preset's albedo network (map, the paper's U-Net; "
                   "photo-affine, the photo less a predicted grey offset).")
@click.option("--learning-rate", default=0.002, show_default=True)
@click.option("--lr-gamma", default=1e-4, show_default=True,
              help="Gamma of the inv policy: lr = learning_rate (1 + gamma step)^-1.")
@click.option("--batch-size", default=16, show_default=True)
@click.option("--labeled-epochs", default=10, show_default=True)
@click.option("--self-augmented-epochs", default=10, show_default=True)
@click.option("--unlabeled-per-labeled", type=click.FloatRange(min=0), default=1.0,
              show_default=True,
              help="Self-augmented minibatches per labeled one after the labeled epochs "
                   "(a fraction allowed: 0.5 interleaves one with every other).")
@click.option("--unlabeled-limit", type=int, default=None)
@click.option("--albedo-loss", type=click.Choice(ALBEDO_LOSSES), default="linear",
              show_default=True, help="Squared error of the relative albedo (linear, the "
                                      "paper's) or of its logarithm (log).")
@click.option("--relit-loss-weight", default=0.0, show_default=True,
              help="Weight of the relit loss (the estimate and the truth rendered under new "
                   "lighting) added to the parameter losses.")
@click.option("--relit-loss-size", default=64, show_default=True,
              help="Side (px) of the relit loss's renders.")
@click.option("--relit-loss-form", type=click.Choice(RELIT_LOSS_FORMS), default="log",
              show_default=True,
              help="How the relit loss compares the renders: squared difference of log(1 + x) "
                   "(log), or the evaluation's relit RMSE of the clamped renders (rmse).")
@click.option("--relit-partners", type=click.Choice(RELIT_PARTNERS), default="truth",
              show_default=True,
              help="What the relit loss renders for the labels of networks not trained: the "
                   "truth's, or the frozen networks' own estimates (each network then learns "
                   "what relights best beside the others' errors).")
@click.option("--max-view-angle", default=0.0, show_default=True)
@click.option("--probe-tilts", default=0, show_default=True,
              help="Tilted copies of each training probe added to them (a low sun or lamp "
                   "brought overhead, where a flat sample mirrors it).")
@click.option("--max-probe-tilt", default=60.0, show_default=True,
              help="Largest tilt (degrees) of those copies.")
@click.option("--seed", default=0, show_default=True)
@click.option("--checkpoint-every", default=500, show_default=True)
@click.option("--log-every", default=50, show_default=True)
@click.option("--device", default="cpu", show_default=True, help="torch device (cpu, cuda).")
def main(network_name: str, input_size: int | None, width: int | None, levels: int | None,
         homogeneous_pooling: str | None, albedo_network: str | None, learning_rate: float,
         lr_gamma: float, train_networks: str, crop_scales: str, **options: Any) -> None:
    """Train SVBRDF-net, with self-augmentation when unlabeled photos are given."""
    main_process = os.environ.get("RANK", "0") == "0"  # under torchrun, only rank 0 logs
    logging.basicConfig(level=logging.INFO if main_process else logging.WARNING,
                        format="%(asctime)s %(levelname)s %(message)s")
    overrides = {"input_size": input_size, "width": width, "levels": levels,
                 "homogeneous_pooling": homogeneous_pooling, "albedo_network": albedo_network}
    try:
        network = dataclasses.replace(NETWORKS[network_name],
                                      **{k: v for k, v in overrides.items() if v is not None})
        cfg = TrainConfig(network=network, optimizer=OptimizerConfig(learning_rate=learning_rate,
                                                                    lr_gamma=lr_gamma),
                          train_networks=tuple(name.strip() for name in
                                               train_networks.split(",") if name.strip()),
                          crop_scales=_whole_numbers(crop_scales, "--crop-scales"),
                          **options)
        if main_process:
            click.echo(json.dumps(dataclasses.asdict(cfg), indent=2))
        history = run(cfg)
    except (InputError, ValueError) as error:
        raise click.ClickException(str(error)) from None
    except TrainingStopped as stopped:  # exit status 128 + signal, as if the signal had ended it
        click.echo(f"sa-train: {stopped}", err=True)
        raise SystemExit(128 + (stopped.signal_number or signal.SIGTERM)) from None
    if history["test"]:
        click.echo(json.dumps({"final_test": history["test"][-1]}))


def _whole_numbers(text, option):
    """The comma-separated whole numbers of an option, as a tuple."""
    try:
        return tuple(int(value) for value in text.split(","))
    except ValueError:
        raise click.BadParameter(f"'{text}' is not a comma-separated list of whole numbers",
                                 param_hint=option) from None


if __name__ == "__main__":
    main()
