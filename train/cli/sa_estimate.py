"""Command line of ``sa-estimate``: parse options, build an EstimateConfig and an Estimator,
call run(cfg, estimator)."""

import json

import click

from render.common.errors import InputError
from train.estimation.batch import DEFAULT_PROBES, EstimateConfig, run
from train.estimation.estimator import Estimator
from train.estimation.full_resolution import MAX_SIDE
from train.estimation.network_choice import CLASSES, DEFAULT_CLASS


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.argument("photos", nargs=-1, required=True, type=click.Path())
@click.option("--model", type=click.Path(), default=None,
              help="A model file (.safetensors), an sa-train checkpoint (.pt) or a run folder "
                   "(its newest checkpoint). Default: the shipped network of --class.")
@click.option("--class", "material_class", type=click.Choice(CLASSES),
              default=DEFAULT_CLASS,
              show_default=True,
              help="The photo's kind of material, when no --model is given: a shipped class "
                   "network with the lobe it reads, or unknown: the plastic network's maps "
                   "with a fixed lobe (relative specular 0.08, Ward alpha 0.25), the safest "
                   "estimate of real materials on the real-set validation (models/README.md).")
@click.option("--out", required=True, type=click.Path(),
              help="Output folder. Run again with the same options, a cut-off batch "
                   "continues: finished photos are skipped.")
@click.option("--overwrite", is_flag=True,
              help="Estimate every photo again, replacing its folder, even if the folder was "
                   "made with other options.")
@click.option("--probe", "probes", type=click.Path(), multiple=True,
              help="HDR probe to relight the estimate under (repeat for several; the first "
                   "also lights the preview and the Mitsuba scene). Default: the three "
                   "bundled probes, park, env-studio and potsdamer_platz.")
@click.option("--max-side", type=int, default=MAX_SIDE, show_default=True,
              help="Longest side of the albedo and normal maps (px).")
@click.option("--device", default="cpu", show_default=True, help="torch device (cpu, cuda).")
def main(photos: tuple[str, ...], model: str | None, material_class: str, out: str,
         overwrite: bool, probes: tuple[str, ...], max_side: int, device: str) -> None:
    """Estimate the reduced SVBRDF of each PHOTO."""
    try:
        cfg = EstimateConfig(photos, out, tuple(probes) or DEFAULT_PROBES, overwrite)
        reports = run(cfg, Estimator(model, material_class, device, max_side))
    except (InputError, ValueError) as error:
        raise click.ClickException(str(error)) from None
    for report in reports:
        click.echo(json.dumps(report))


if __name__ == "__main__":
    main()
