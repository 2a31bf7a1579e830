"""Command line of ``render-dataset``: parse options, build a DatasetConfig, call run(cfg)."""

import dataclasses
import json
import logging
from typing import Any

import click

from render.common.errors import InputError
from render.dataset.config import DatasetConfig
from render.dataset.generator import run


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--probes", required=True, type=click.Path(), help="Folder of HDR probes.")
@click.option("--svbrdfs", required=True, type=click.Path(), help="Folder of material folders.")
@click.option("--out", required=True, type=click.Path(), help="Output dataset folder.")
@click.option("--resolution", default=256, show_default=True, help="Output sample size (px).")
@click.option("--render-size", type=int, default=None,
              help="Shorter side of each render (px) [default: 2 x resolution].")
@click.option("--rotations", default=9, show_default=True, help="Renders per (material, probe).")
@click.option("--crops", default=4, show_default=True, help="Samples cut from each render.")
@click.option("--spp", default=1024, show_default=True, help="Samples per pixel.")
@click.option("--sampler", default="multijitter", show_default=True, help="Mitsuba sampler.")
@click.option("--seed", default=0, show_default=True, help="Seed of all random choices.")
@click.option("--workers", default=1, show_default=True,
              help="Worker processes (with --ray alone: CPUs of the local Ray instance).")
@click.option("--ray", is_flag=False, flag_value="local", default=None, metavar="[ADDRESS]",
              help="Render as Ray tasks on the cluster at ADDRESS (auto, HOST:6379, "
                   "ray://HOST:10001); alone, on a Ray instance started here.")
@click.option("--ray-chunk", default=4, show_default=True,
              help="Render tasks (material, probe, rotation) per Ray task.")
@click.option("--ray-cpus-per-task", default=1, show_default=True,
              help="CPUs each Ray task reserves (Mitsuba threads).")
@click.option("--variant", default="llvm_ad_rgb", show_default=True, help="Mitsuba variant.")
@click.option("--test-materials", default=0.2, show_default=True,
              help="Fraction of materials held out for testing.")
@click.option("--test-probes", default=0.2, show_default=True,
              help="Fraction of probes held out for testing.")
@click.option("--exposure-key", default=0.18, show_default=True,
              help="Mean luminance after auto-exposure.")
@click.option("--max-view-angle", default=0.0, show_default=True,
              help="Largest random view tilt from the normal (degrees).")
def main(render_size: int | None, **options: Any) -> None:
    """Render labeled (photo, reduced SVBRDF) pairs with Mitsuba 3."""
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    cfg = DatasetConfig(render_size=render_size or 2 * options["resolution"], **options)
    click.echo(json.dumps(dataclasses.asdict(cfg), indent=2))
    try:
        index = run(cfg)
    except (InputError, ValueError) as error:
        raise click.ClickException(str(error)) from None
    click.echo(f"{index['count']} samples ({index['splits']['train']} train, "
               f"{index['splits']['test']} test) in {cfg.out}")


if __name__ == "__main__":
    main()
