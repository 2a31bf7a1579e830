"""Fit the JointReading head of a model file and write the model with it
(train.fits.joint_reading; models/README.md, "The joint reading").

    .venv/bin/python scripts/fit_joint_reading.py MODEL.safetensors OUT.safetensors \
        --maps MAPS --probes PROBES_TRAIN --work WORK

The networks of MODEL are kept as they are; a head MODEL already has is replaced. WORK keeps
the prepared photos and relights (re-run with the same options: the fit starts from them) and
fit.png, the loss and the relit error of the photos kept out of the fit. Prints a JSON line:
that error with and without the head.
"""

import json
from pathlib import Path

import click
import torch

from render.common.errors import InputError
from train.fits.joint_reading import FitConfig, fit
from train.fits.part_fitting import fit_part_onto_model


@click.command()
@click.argument("model", type=click.Path(exists=True, dir_okay=False))
@click.argument("out", type=click.Path())
@click.option("--maps", required=True, type=click.Path(exists=True, file_okay=False),
              help="Folder of material folders the photos are rendered from.")
@click.option("--probes", required=True, type=click.Path(exists=True, file_okay=False),
              help="Training probes.")
@click.option("--work", required=True, type=click.Path(), help="Folder for the prepared data.")
@click.option("--photos", default=FitConfig.photos, show_default=True)
@click.option("--relights", default=FitConfig.relights, show_default=True)
@click.option("--mix-specular/--own-specular", default=FitConfig.mix_specular,
              show_default=True, help="Photos of mixed specular pairs, or of each set's own.")
@click.option("--steps", default=FitConfig.steps, show_default=True)
@click.option("--seed", default=FitConfig.seed, show_default=True)
def main(model, out, maps, probes, work, photos, relights, mix_specular, steps, seed):
    torch.manual_seed(seed)
    cfg = FitConfig(work=work, maps=maps, photos=photos, relights=relights,
                    mix_specular=mix_specular, steps=steps, seed=seed)
    specular = "--mix-specular" if mix_specular else "--own-specular"
    command = (f"scripts/fit_joint_reading.py --photos {photos} --relights {relights} "
               f"{specular} --steps {steps} --seed {seed}, maps folder {Path(maps).name}")
    try:
        report = fit_part_onto_model(model, out, "joint_reading", probes,
                                     lambda net, bank: fit(cfg, net, bank), command)
    except (InputError, ValueError) as error:
        raise click.ClickException(str(error)) from None
    print(json.dumps(report))


if __name__ == "__main__":
    main()
