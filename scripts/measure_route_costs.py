"""Measure what each shipped network costs on each material route: the costs the material
classifier's router weighs (train.estimation.network_choice.ClassRouter).

For every route (wood, plastic, metal, general) and every shipped network, the mean relit RMSE
(sa-evaluate's measure, train.evaluation.estimate_evaluation) of that network's estimates of ``--samples``
photos rendered by the torch renderer from the route's validation sets (``--val ROUTE=FOLDER``)
under ``--probes``. Prints the cost matrix as JSON (rows: the photo's route, columns: the
network) and writes it to ``--out``, the file ``train_material_classifier.py --costs`` embeds
in the classifier.

    .venv/bin/python scripts/measure_route_costs.py --val wood=VAL/wood --val plastic=VAL/plastic \
        --val metal=VAL/metal --val general=VAL/general --probes PROBES_TRAIN --out costs.json
"""

import json
import tempfile
from pathlib import Path

import click

from render.common.atomic_files import atomic_path
from train.estimation.material_classifier import ROUTES, route_folders
from train.estimation.network_choice import FixedNetwork
from train.evaluation.estimate_evaluation import EvaluationConfig, run
from train.networks.model_files import load_network, shipped_model_path


@click.command()
@click.option("--val", "folders", multiple=True, required=True,
              help="ROUTE=FOLDER of validation material sets, one per route.")
@click.option("--probes", required=True, type=click.Path(), help="Probes (lighting, relighting).")
@click.option("--samples", default=40, show_default=True, help="Photos per route.")
@click.option("--out", required=True, type=click.Path(), help="Cost matrix JSON file.")
def main(folders, probes, samples, out):
    try:
        folders = route_folders(folders)
    except ValueError as error:
        raise click.BadParameter(str(error)) from None
    networks = {name: FixedNetwork(load_network(shipped_model_path(name))) for name in ROUTES}
    costs, naive = [], []
    with tempfile.TemporaryDirectory() as work:
        for route in ROUTES:
            row = []
            for name, choice in networks.items():
                cfg = EvaluationConfig(out=str(Path(work) / f"{route}-{name}"), probes=probes,
                                       materials=folders[route], samples=samples, seed=1)
                mean = run(cfg, choice)["mean"]
                row.append(round(mean["model"]["relit_rmse"], 5))
            naive.append(round(mean["naive"]["relit_rmse"], 5))
            costs.append(row)
            click.echo(f"{route}: {dict(zip(ROUTES, row))}, naive {naive[-1]}", err=True)
    report = {"routes": ROUTES, "costs": costs, "naive": naive, "samples": samples,
              "validation": folders, "probes": str(probes)}
    with atomic_path(Path(out)) as tmp:
        tmp.write_text(json.dumps(report, indent=1))
    click.echo(json.dumps(report))


if __name__ == "__main__":
    main()
