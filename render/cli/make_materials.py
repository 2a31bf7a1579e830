"""Command line of ``make-materials``: parse options, build a MakeMaterialsConfig, call run(cfg)."""

import json
import logging
from typing import Any

import click

from render.common.errors import InputError
from render.materials.make_materials import MakeMaterialsConfig, run
from render.materials.procedural.material_set import GENERATORS


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--class", "material_class", required=True, type=click.Choice(sorted(GENERATORS)),
              help="Material class to make.")
@click.option("--count", default=8, show_default=True, type=click.IntRange(min=1),
              help="Number of sets.")
@click.option("--out", required=True, type=click.Path(), help="Folder of material folders.")
@click.option("--seed", default=0, show_default=True, help="Seed of all random choices.")
@click.option("--resolution", default=512, show_default=True, type=click.IntRange(min=8),
              help="Map size (px, square).")
@click.option("--augment", type=click.Path(), default=None,
              help="Make sets from the real sets of the class in this folder instead.")
@click.option("--probe", type=click.Path(), default=None,
              help="Also render the contact sheet's sets under this probe with Mitsuba.")
@click.option("--spp", default=128, show_default=True, type=click.IntRange(min=1),
              help="Samples per pixel of those renders.")
def main(**options: Any) -> None:
    """Write COUNT material sets of one class, and a contact sheet of the first few."""
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    cfg = MakeMaterialsConfig(**options)
    try:
        summary = run(cfg)
    except (InputError, ValueError) as error:
        raise click.ClickException(str(error)) from None
    click.echo(json.dumps(summary))


if __name__ == "__main__":
    main()
