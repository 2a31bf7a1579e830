"""Measure: the shipped plastic file without view averaging, on the real-set validation.

View averaging (NetworkConfig.view_averaging) averages the joint reading head's readings over
the photo's 8 dihedral views, about 4.8x the network time. Here the same file with the flag off
is measured on scripts/real_validation.py's validation photos (the same photos as the shipped
files'), as the choice ``plastic-no-view-averaging``.

    .venv/bin/python experiments/plastic_without_view_averaging.py --out OUT
"""

import dataclasses
import sys
from pathlib import Path

import click

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "scripts"))
from real_validation import (FOLDS, SHARED, SHIPPED_TRAINING_SETS,  # noqa: E402
                             VALIDATION_PROBES, linked_folder, summarize)

from train.estimation.network_choice import FixedNetwork  # noqa: E402
from train.evaluation.estimate_evaluation import EvaluationConfig, run  # noqa: E402
from train.networks.model_files import load_network, shipped_model_path  # noqa: E402

NAME = "plastic-no-view-averaging"


@click.command()
@click.option("--out", required=True, type=click.Path())
@click.option("--samples", default=60, show_default=True)
def main(out, samples):
    out = Path(out)
    probes = linked_folder(out / "probes-validation",
                           [f"{n}.exr" for n in VALIDATION_PROBES], SHARED / "probes")
    net = load_network(shipped_model_path("plastic"))
    net.config = dataclasses.replace(net.config, view_averaging=False)
    for fold, sets in FOLDS.items():
        if (out / fold / NAME / "results.json").is_file():
            continue
        kept = [s for s in sets if s not in SHIPPED_TRAINING_SETS]
        folder = linked_folder(out / "sets" / fold, kept, SHARED / "svbrdfs")
        run(EvaluationConfig(out=str(out / fold / NAME), probes=str(probes),
                             materials=str(folder), samples=samples), FixedNetwork(net))
    summarize(out, list(FOLDS), ["plastic", NAME])
    click.echo((out / "table.md").read_text())


if __name__ == "__main__":
    main()
