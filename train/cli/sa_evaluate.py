"""Command line of ``sa-evaluate``: parse options, build an EvaluationConfig, call run(cfg)."""

import json
from typing import Any

import click

from render.common.errors import InputError
from train.estimation.network_choice import CLASSES, DEFAULT_CLASS, network_choice
from train.evaluation.estimate_evaluation import EvaluationConfig, run


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--model", type=click.Path(), default=None,
              help="Model file (.safetensors), sa-train checkpoint (.pt) or run folder.")
@click.option("--class", "material_class", type=click.Choice(CLASSES),
              default=DEFAULT_CLASS, show_default=True,
              help="The choice to evaluate when no --model is given (sa-estimate's --class).")
@click.option("--dataset", "datasets", type=click.Path(), multiple=True,
              help="render-dataset folder whose --split is evaluated (repeatable).")
@click.option("--materials", type=click.Path(), default=None,
              help="Or material folders, rendered here under --probes (torch renderer).")
@click.option("--probes", required=True, type=click.Path(),
              help="HDR probes: relighting (and the lighting of --materials).")
@click.option("--out", required=True, type=click.Path(), help="Folder for results and figure.")
@click.option("--split", type=click.Choice(["test", "train", "all"]), default="test",
              show_default=True)
@click.option("--samples", default=64, show_default=True,
              help="Samples rendered from --materials; at most this many of a dataset's split.")
@click.option("--sample-size", default=256, show_default=True, help="Their side (px).")
@click.option("--relights", default=3, show_default=True,
              help="Novel probes each estimate is relit under.")
@click.option("--seed", default=0, show_default=True)
@click.option("--device", default="cpu", show_default=True, help="torch device (cpu, cuda).")
@click.option("--per-sample/--means-only", default=False, show_default=True,
              help="Print every sample's errors too (results.json always has them).")
def main(model: str | None, material_class: str, per_sample: bool, **options: Any) -> None:
    """Evaluate MODEL's estimates against the truth and the naive baseline; JSON on stdout."""
    try:
        cfg = EvaluationConfig(**options)
        report = run(cfg, network_choice(model, material_class, cfg.device))
    except (InputError, ValueError) as error:
        raise click.ClickException(str(error)) from None
    if not per_sample:
        report = {key: value for key, value in report.items() if key != "per_sample"}
    click.echo(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
