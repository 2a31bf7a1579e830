"""Train the material classifier (train.estimation.material_classifier) and measure it on held-out data.

Each step renders a minibatch of ``--per-route`` labeled photos of every route with the torch
renderer (train.data.map_samples.MapSampler: a random 256 px crop of a random material of the
route's folder, at a random scale of 1 or 2, under a random probe of ``--probes`` at a random
rotation, auto-exposed), and takes one Adam step of the cross entropy. The random choices of
step k come from a generator seeded by (seed, k), and a checkpoint (``RUN/checkpoint.pt``,
read back with torch's safe loader) is written every ``--checkpoint-every`` steps, so a run
that is cut off continues where it stopped when started again with the same command (a larger
``--steps`` trains on, with the learning-rate schedule of the first start).

At the end it writes ``RUN/loss.png`` (the loss curve), exports the classifier with the cost
matrix of ``--costs`` (written by scripts/measure_route_costs.py) to ``--export`` and, with
``--test ROUTE=FOLDER`` and ``--test-probes``, prints as JSON the confusion matrix over
``--test-samples`` photos per route rendered the same way from those (held-out) sets.

``--route-weight ROUTE=W`` weighs a route's photos in the cross entropy (1 for routes not
named). A route trained on many varied sets (plastic: 1,200 procedural sets) otherwise becomes
the classifier's answer for anything unfamiliar, and a route of few sets (general: 9 real
ones) loses its own photos to it; a weight W moves the classifier's odds for that route by
about a factor W, as a prior would.

    .venv/bin/python scripts/train_material_classifier.py --maps wood=MAPS/wood \
        --maps plastic=MAPS/plastic --maps metal=MAPS/metal --maps general=REAL_SETS \
        --probes PROBES_TRAIN --run RUN --steps 1000 --costs costs.json \
        --export models/material-classifier.safetensors

``--plastic-or-metal`` trains the plastic-or-metal network instead (train.estimation.material_classifier):
photos of the plastic and metal routes only (``--maps`` names just those two), and ``--export``
writes the classifier file ``--attach-to`` with this network attached (its first network and
costs as they were):

    .venv/bin/python scripts/train_material_classifier.py --plastic-or-metal \
        --maps plastic=MAPS/plastic --maps metal=MAPS/metal --probes PROBES_TRAIN --run RUN_PM \
        --steps 2000 --attach-to CLASSIFIER --export models/material-classifier.safetensors
"""

import json
from pathlib import Path

import click
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402
from torch.nn import functional  # noqa: E402
from tqdm import tqdm  # noqa: E402

from render.common.atomic_files import atomic_path  # noqa: E402
from render.common.errors import InputError  # noqa: E402
from render.common.probes import find_probes, load_probe  # noqa: E402
from render.torch_renderer.renderer import ProbeBank  # noqa: E402
from train.data.map_samples import MapSampler  # noqa: E402
from train.estimation.material_classifier import (  # noqa: E402
    FORMAT,
    ROUTES,
    MaterialClassifier,
    load_classifier,
    route_folders,
    save_classifier,
)
from train.networks.model_files import model_metadata  # noqa: E402

PHOTO_SIZE = 256
RENDER_SIZE = 512
CROP_SCALES = (1, 2)


PLASTIC_OR_METAL = ("plastic", "metal")
"""The routes the plastic-or-metal network is trained on."""


def samplers(folders, probes_folder):
    """{route: MapSampler} of ``folders`` ({route: folder}), in the order of ROUTES."""
    bank = ProbeBank([load_probe(path).radiance for path in find_probes(probes_folder)])
    return {route: MapSampler(folders[route], bank, range(len(bank)), PHOTO_SIZE, RENDER_SIZE,
                              crop_scales=CROP_SCALES) for route in ROUTES if route in folders}


def minibatch(route_samplers, rng, per_route):
    """Photos (n, 3, S, S) and their route indices in ROUTES (n,)."""
    photos = [sampler.batch(rng, per_route)["image"] for sampler in route_samplers.values()]
    labels = torch.tensor([ROUTES.index(route) for route in route_samplers])
    return torch.cat(photos), labels.repeat_interleave(per_route)


def route_weights(pairs):
    """Cross-entropy weights (len(ROUTES),) of ``ROUTE=W`` strings; 1 for routes not named."""
    weights = dict.fromkeys(ROUTES, 1.0)
    for pair in pairs:
        route, _, value = pair.partition("=")
        if route not in weights:
            raise ValueError(f"--route-weight {pair}: route {route!r} is not one of "
                             f"{list(ROUTES)}")
        try:
            weights[route] = float(value)
        except ValueError:
            raise ValueError(f"--route-weight {pair}: {value!r} is not a number") from None
        if not weights[route] > 0:
            raise ValueError(f"--route-weight {pair}: the weight must be positive")
    return torch.tensor([weights[route] for route in ROUTES])


def write_loss_curve(path, history):
    steps, losses = zip(*history)
    window = max(1, len(losses) // 50)
    smooth = np.convolve(losses, np.ones(window) / window, mode="valid")
    figure, axes = plt.subplots(figsize=(6, 3.5))
    axes.plot(steps, losses, color="0.8", label="per step")
    axes.plot(steps[window - 1:], smooth, color="C0", label=f"mean of {window}")
    axes.set(xlabel="step", ylabel="cross entropy", yscale="log",
             title="material classifier training")
    axes.legend()
    figure.tight_layout()
    with atomic_path(Path(path)) as tmp:
        figure.savefig(tmp, format="png", dpi=100)
    plt.close(figure)


@click.command()
@click.option("--maps", "maps", multiple=True, required=True, help="ROUTE=FOLDER of material "
              "folders, one per route (wood, plastic, metal, general).")
@click.option("--probes", required=True, type=click.Path(), help="Training probes.")
@click.option("--run", "run_folder", required=True, type=click.Path(), help="Run folder.")
@click.option("--steps", default=1000, show_default=True)
@click.option("--per-route", default=6, show_default=True, help="Photos per route per step.")
@click.option("--route-weight", "route_weight_pairs", multiple=True,
              help="ROUTE=W: weight of a route's photos in the loss (default 1).")
@click.option("--learning-rate", default=1e-3, show_default=True)
@click.option("--seed", default=0, show_default=True)
@click.option("--checkpoint-every", default=100, show_default=True)
@click.option("--export", type=click.Path(), default=None, help="Classifier file to write.")
@click.option("--costs", type=click.Path(exists=True, dir_okay=False), default=None,
              help="Cost matrix JSON of scripts/measure_route_costs.py (needed by --export).")
@click.option("--plastic-or-metal", is_flag=True, help="Train the plastic-or-metal network "
              "on the plastic and metal routes only.")
@click.option("--attach-to", type=click.Path(exists=True, dir_okay=False), default=None,
              help="With --plastic-or-metal: the classifier file --export writes with this "
              "network attached.")
@click.option("--test", "tests", multiple=True, help="ROUTE=FOLDER of held-out sets.")
@click.option("--test-probes", type=click.Path(), default=None, help="Held-out probes.")
@click.option("--test-samples", default=60, show_default=True, help="Test photos per route.")
def main(maps, probes, run_folder, steps, per_route, route_weight_pairs, learning_rate, seed,
         checkpoint_every, export, costs, plastic_or_metal, attach_to, tests, test_probes,
         test_samples):
    if export and not (attach_to if plastic_or_metal else costs):
        raise click.UsageError("--export needs --attach-to" if plastic_or_metal
                               else "--export needs --costs")
    if attach_to and not plastic_or_metal:
        raise click.UsageError("--attach-to is for --plastic-or-metal")
    routes = PLASTIC_OR_METAL if plastic_or_metal else ROUTES
    try:
        attached = load_classifier(attach_to) if export and plastic_or_metal else None
    except InputError as error:
        raise click.ClickException(str(error)) from None
    try:
        folders = route_folders(maps, routes)
        test_folders = route_folders(tests, routes) if tests else None
        weights = route_weights(route_weight_pairs)
    except ValueError as error:
        raise click.BadParameter(str(error)) from None
    torch.manual_seed(seed)
    run = Path(run_folder)
    run.mkdir(parents=True, exist_ok=True)
    classifier = MaterialClassifier()
    optimizer = torch.optim.Adam(classifier.parameters(), lr=learning_rate, weight_decay=1e-4)
    schedule = torch.optim.lr_scheduler.CosineAnnealingLR(optimizer, steps)
    checkpoint, start, history = run / "checkpoint.pt", 0, []
    if checkpoint.is_file():
        state = torch.load(checkpoint, map_location="cpu", weights_only=True)
        classifier.load_state_dict(state["model"])
        optimizer.load_state_dict(state["optimizer"])
        schedule.load_state_dict(state["schedule"])
        start, history = state["step"], [tuple(item) for item in state["history"]]
        torch.set_rng_state(state["torch_rng"])
    route_samplers = samplers(folders, probes)
    classifier.train()
    for step in tqdm(range(start, steps), initial=start, total=steps, desc="classifier"):
        photos, labels = minibatch(route_samplers, np.random.default_rng([seed, step]),
                                   per_route)
        loss = functional.cross_entropy(classifier(photos), labels, weight=weights)
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        schedule.step()
        history.append((step + 1, loss.item()))
        if (step + 1) % checkpoint_every == 0 or step + 1 == steps:
            with atomic_path(checkpoint) as tmp:
                torch.save({"model": classifier.state_dict(), "optimizer": optimizer.state_dict(),
                            "schedule": schedule.state_dict(), "step": step + 1,
                            "history": history, "torch_rng": torch.get_rng_state()}, tmp)
    write_loss_curve(run / "loss.png", history)
    classifier.eval()
    if attached is not None:
        attached.attach_plastic_or_metal(classifier)
        kept = model_metadata(attach_to, FORMAT, "classifier")
        save_classifier(attached, export, attached.costs.tolist(), kept | {
            "plastic_or_metal_recipe": f"scripts/train_material_classifier.py "
                                       f"--plastic-or-metal, {steps} steps of {per_route} "
                                       f"photos per route, route weights "
                                       f"{dict(zip(ROUTES, weights.tolist()))}, "
                                       f"lr {learning_rate}, seed {seed}",
            "plastic_or_metal_trained_on": folders})
    elif export:
        measured = json.loads(Path(costs).read_text())
        if tuple(measured["routes"]) != ROUTES:
            raise click.UsageError(f"{costs}: routes {measured['routes']}, expected {ROUTES}")
        save_classifier(classifier, export, measured["costs"], {
            "costs_measured_on": measured["validation"],
            "recipe": f"scripts/train_material_classifier.py, {steps} steps of {per_route} "
                      f"photos per route, route weights {dict(zip(ROUTES, weights.tolist()))}, "
                      f"lr {learning_rate}, seed {seed}",
            "trained_on": folders})
    if test_folders:
        test_samplers = samplers(test_folders, test_probes)
        confusion = np.zeros((len(test_samplers), len(ROUTES)), dtype=int)
        rng = np.random.default_rng([seed, 0, 1])  # test photos; training draws (seed, step)
        for truth, sampler in enumerate(test_samplers.values()):
            for start_index in range(0, test_samples, 20):
                count = min(20, test_samples - start_index)
                chosen = classifier.probabilities(sampler.batch(rng, count)["image"]).argmax(1)
                for answer in chosen.tolist():
                    confusion[truth, answer] += 1
        right = sum(confusion[row, ROUTES.index(route)]
                    for row, route in enumerate(test_samplers))
        click.echo(json.dumps({"routes": ROUTES, "test_routes": list(test_samplers),
                               "confusion (rows: test routes, columns: answer)":
                               confusion.tolist(), "accuracy": float(right / confusion.sum())}))


if __name__ == "__main__":
    main()
