"""Export a trained run as a shipped model file (models/README.md): float16 safetensors.

    .venv/bin/python scripts/export_model.py RUN_OR_CHECKPOINT OUT.safetensors \
        --class wood --recipe "the sa-train command"
"""

from pathlib import Path

import click

from render.common.errors import InputError
from train.networks.model_files import load_network, save_model


@click.command()
@click.argument("model", type=click.Path())
@click.argument("out", type=click.Path())
@click.option("--class", "material_class", required=True, help="Material class it was trained on.")
@click.option("--recipe", default="", help="The command that trained it.")
def main(model, out, material_class, recipe):
    try:
        net = load_network(model)
        save_model(net, out, {"class": material_class, "recipe": recipe,
                              "trained_from": Path(net.source).name})
    except (InputError, ValueError) as error:
        raise click.ClickException(str(error)) from None


if __name__ == "__main__":
    main()
