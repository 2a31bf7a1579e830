"""Command line of ``sa-estimate``: parse options, build an EstimateConfig, call run(cfg)."""

import json

import click

from render.common.errors import InputError
from train.estimate import DEFAULT_PROBE, EstimateConfig, run
from train.model_files import SHIPPED, shipped_model_path


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.argument("photos", nargs=-1, required=True, type=click.Path())
@click.option("--model", type=click.Path(), default=None,
              help="A model file (.safetensors), an sa-train checkpoint (.pt) or a run folder "
                   "(its newest checkpoint). Default: the shipped network of --class.")
@click.option("--class", "material_class", type=click.Choice(SHIPPED), default="general",
              show_default=True, help="Shipped network to use when no --model is given.")
@click.option("--out", required=True, type=click.Path(), help="Output folder.")
@click.option("--probe", type=click.Path(), default=str(DEFAULT_PROBE), show_default=True,
              help="HDR probe of the relit preview and the Mitsuba scene.")
@click.option("--device", default="cpu", show_default=True, help="torch device (cpu, cuda).")
def main(model, material_class, **options):
    """Estimate the reduced SVBRDF of each PHOTO."""
    try:
        cfg = EstimateConfig(model=str(model or shipped_model_path(material_class)), **options)
        reports = run(cfg)
    except (InputError, ValueError) as error:
        raise click.ClickException(str(error)) from None
    for report in reports:
        click.echo(json.dumps(report))


if __name__ == "__main__":
    main()
