"""Write a model file with view averaging on (train.networks.svbrdf_net.NetworkConfig.view_averaging: the
joint reading head's readings averaged over the photo's 8 dihedral views); the weights are
kept as they are.

    .venv/bin/python scripts/set_view_averaging.py MODEL.safetensors OUT.safetensors
"""

import dataclasses

import click

from render.common.errors import InputError
from train.networks.model_files import FORMAT, load_network, model_metadata, save_model


@click.command()
@click.argument("model", type=click.Path(exists=True, dir_okay=False))
@click.argument("out", type=click.Path())
def main(model, out):
    try:
        metadata = model_metadata(model, FORMAT, "model")
        net = load_network(model)
        if not net.config.joint_reading:
            raise InputError(model, "view averaging needs the joint reading head")
        net.config = dataclasses.replace(net.config, view_averaging=True)
        save_model(net, out, metadata | {"recipe": f"{metadata.get('recipe', '')}; then "
                                                   "scripts/set_view_averaging.py"})
    except (InputError, ValueError) as error:
        raise click.ClickException(str(error)) from None


if __name__ == "__main__":
    main()
