"""Fit the AlbedoCorrection of a photo-affine model file and write the model with it
(train.fits.albedo_correction; models/README.md, "The albedo correction").

    .venv/bin/python scripts/fit_albedo_correction.py MODEL.safetensors OUT.safetensors \
        --maps MAPS --probes PROBES_TRAIN --work WORK

The networks of MODEL (and its JointReading head) are kept as they are; a correction MODEL
already has is replaced. WORK keeps the prepared photos and the fit's state (re-run with the
same options: it resumes) and fit.png, the loss and the albedo error of the photos kept out
of the fit. Prints a JSON line: that error with and without the correction.
"""

import json
from pathlib import Path

import click

from render.common.errors import InputError
from train.fits.albedo_correction import FitConfig, fit
from train.fits.part_fitting import fit_part_onto_model


@click.command()
@click.argument("model", type=click.Path(exists=True, dir_okay=False))
@click.argument("out", type=click.Path())
@click.option("--maps", required=True, type=click.Path(exists=True, file_okay=False),
              help="Folder of material folders the photos are rendered from.")
@click.option("--probes", required=True, type=click.Path(exists=True, file_okay=False),
              help="Training probes.")
@click.option("--work", required=True, type=click.Path(), help="Folder for the fit's state.")
@click.option("--photos", default=FitConfig.photos, show_default=True)
@click.option("--steps", default=FitConfig.steps, show_default=True)
@click.option("--seed", default=FitConfig.seed, show_default=True)
def main(model, out, maps, probes, work, photos, steps, seed):
    cfg = FitConfig(work=work, maps=maps, photos=photos, steps=steps, seed=seed)
    command = (f"scripts/fit_albedo_correction.py --photos {photos} --steps {steps} "
               f"--seed {seed}, maps folder {Path(maps).name}")
    try:
        report = fit_part_onto_model(model, out, "albedo_correction", probes,
                                     lambda net, bank: fit(cfg, net, bank), command)
    except (InputError, ValueError) as error:
        raise click.ClickException(str(error)) from None
    print(json.dumps(report))


if __name__ == "__main__":
    main()
