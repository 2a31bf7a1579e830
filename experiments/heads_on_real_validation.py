"""Try: do the shipped files' fitted heads earn their keep on the real-set validation?

The plastic file carries a JointReading head and an AlbedoCorrection, the wood file a
JointReading head (train.networks.svbrdf_net), each fit after its networks by a loop of its own
(train.fits). Each variant here is the shipped file less some of them (the other weights
bit-identical), written to ``OUT/files/<class>-without-<parts>.safetensors`` and measured on the
real-set validation of scripts/real_validation.py beside the shipped files, on the same photos.

    .venv/bin/python experiments/heads_on_real_validation.py --out OUT \
        [--variants plastic:joint,plastic:correction,plastic:joint+correction,wood:joint]
"""

import dataclasses
import sys
from pathlib import Path

import click

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "scripts"))
from real_validation import evaluate_choice, report_beside_shipped  # noqa: E402

from train.estimation.network_choice import network_choice  # noqa: E402
from train.networks.model_files import (  # noqa: E402
    FORMAT,
    load_network,
    model_metadata,
    save_model,
    shipped_model_path,
)
from train.networks.svbrdf_net import SVBRDFNet  # noqa: E402

PARTS = {"joint": ("joint_reading", "joint."), "correction": ("albedo_correction", "correction.")}
"""A removable part: (its NetworkConfig flag, the prefix of its weights' names)."""


def without_parts(material_class: str, parts: list[str], path: Path) -> None:
    """Write the shipped ``material_class`` file less ``parts`` (keys of PARTS) to ``path``."""
    shipped = shipped_model_path(material_class)
    net = load_network(shipped)
    config = dataclasses.replace(net.config, **{PARTS[p][0]: False for p in parts})
    kept = SVBRDFNet(config)
    state = {name: value for name, value in net.state_dict().items()
             if not name.startswith(tuple(PARTS[p][1] for p in parts))}
    kept.load_state_dict(state)
    metadata = model_metadata(shipped, FORMAT, "model")
    metadata["recipe"] = f"{metadata['recipe']}; then without {' and '.join(parts)}"
    save_model(kept, path, metadata)


@click.command()
@click.option("--out", required=True, type=click.Path())
@click.option("--variants", default="plastic:joint,plastic:correction,plastic:joint+correction,"
              "wood:joint", show_default=True, help="class:part+part,...")
@click.option("--samples", default=60, show_default=True)
@click.option("--relights", default=3, show_default=True)
def main(out, variants, samples, relights):
    out = Path(out)
    names = []
    for material_class in ("plastic", "wood"):
        evaluate_choice(out, "validation", material_class,
                        lambda fold, c=material_class: network_choice(None, c), samples,
                        relights)
    for variant in variants.split(","):
        material_class, parts = variant.split(":")
        name = f"{material_class}-without-{parts}"
        path = out / "files" / f"{name}.safetensors"
        if not path.is_file():
            path.parent.mkdir(parents=True, exist_ok=True)
            without_parts(material_class, parts.split("+"), path)
        names.append(name)
        evaluate_choice(out, "validation", name,
                        lambda fold, p=path: network_choice(p, "plastic"), samples, relights)
    report_beside_shipped(out, names)


if __name__ == "__main__":
    main()
