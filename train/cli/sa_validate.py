"""Command line of ``sa-validate``: parse options, build a ValidationConfig, call run(cfg, patterns)
and, when asked, ratio_table."""

import dataclasses
import json
import logging
from pathlib import Path

import click

from render.common.errors import InputError
from train.brdf_validation.validation import (
    CONFIGURATIONS,
    PATTERNS,
    ValidationConfig,
    ratio_table,
    run,
)


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--probes", required=True, type=click.Path(), help="Folder of HDR probes.")
@click.option("--out", required=True, type=click.Path(), help="Output folder.")
@click.option("--config", "configuration", type=click.Choice(list(CONFIGURATIONS)),
              default="full", show_default=True, help="Sizes: full (GPU), small (CPU), toy.")
@click.option("--patterns", default=",".join(PATTERNS), show_default=True,
              help="Comma-separated labeled sets besides dense.")
@click.option("--ratio-table", "ratio_table_too", is_flag=True,
              help="Also the labeled-unlabeled ratio table (55 more runs).")
@click.option("--seed", default=0, show_default=True)
@click.option("--device", default="cpu", show_default=True)
def main(probes: str, out: str, configuration: str, patterns: str, ratio_table_too: bool,
         seed: int, device: str) -> None:
    """Validate self-augmentation on BRDF-net, as in the paper."""
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(message)s")
    cfg = ValidationConfig(probes=probes, out=out, seed=seed, device=device,
                           **CONFIGURATIONS[configuration])
    click.echo(json.dumps(dataclasses.asdict(cfg), indent=2))
    try:
        _, renderer = run(cfg, tuple(p for p in patterns.split(",") if p))
        click.echo((Path(out) / "table.md").read_text())
        if ratio_table_too:
            ratio_table(cfg, renderer)
            click.echo((Path(out) / "ratio_table.md").read_text())
    except (InputError, ValueError) as error:
        raise click.ClickException(str(error)) from None


if __name__ == "__main__":
    main()
