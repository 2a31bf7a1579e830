"""Benchmark of a training step's parts: a labeled minibatch (rendered on the fly from labeled
maps by the torch renderer, as the shipped models were trained) against a self-augmented one
(provisional prediction of unlabeled photos, then the same renderer), each followed by the same
optimizer step, in one run. Prints JSON (median milliseconds over --repeats steps).

    python benchmarks/minibatch_cost.py [--network compact] [--batch 16] [--repeats 5] \
        [--device cpu|cuda]

Data: the bundled material sets (labeled) and photos (unlabeled), the bundled probes. The
compact network starts from the shipped metal model, so that its provisional predictions are
those of a trained network: an untrained one predicts normals spread over the hemisphere, which
the torch renderer's tables must then cover (docs/performance.md).
"""

import json
import os
import platform
import statistics
import tempfile
import time
from pathlib import Path

import click
import numpy as np
import torch

from train.networks.model_files import shipped_model_path
from train.networks.svbrdf_net import COMPACT_CONFIG, SMALL_CPU_CONFIG, NetworkConfig
from train.training.self_augmentation import random_lightings, self_augmented_batch
from train.training.trainer import Run, TrainConfig

REPO = Path(__file__).resolve().parent.parent
NETWORKS = {"compact": COMPACT_CONFIG, "small": SMALL_CPU_CONFIG, "paper": NetworkConfig()}


def milliseconds(function, device):
    """(result, milliseconds) of ``function()``; on a GPU, its queued work waited for."""
    synchronize = torch.cuda.synchronize if device.startswith("cuda") else (lambda: None)
    synchronize()
    start = time.perf_counter()
    result = function()
    synchronize()
    return result, 1000.0 * (time.perf_counter() - start)


@click.command()
@click.option("--network", type=click.Choice(sorted(NETWORKS)), default="compact",
              show_default=True)
@click.option("--batch", default=16, show_default=True)
@click.option("--repeats", default=5, show_default=True)
@click.option("--device", default="cpu", show_default=True, help="torch device (cpu, cuda).")
def main(network, batch, repeats, device):
    config = NETWORKS[network]
    with tempfile.TemporaryDirectory() as out:
        run = Run(TrainConfig(out=out, probes=str(REPO / "probes"),
                              labeled_maps=str(REPO / "scenes" / "materials"),
                              unlabeled=str(REPO / "scenes" / "photos"), network=config,
                              init_from=(str(shipped_model_path("metal"))
                                         if network == "compact" else None),
                              batch_size=batch, render_size=max(2 * config.input_size, 128),
                              epoch_samples=batch, device=device))
        rng = np.random.default_rng(0)

        def self_augmented():
            chosen = rng.choice(run.unlabeled_indices, batch)
            photos = torch.as_tensor(np.stack([run.unlabeled.image(i) for i in chosen]))
            return self_augmented_batch(run.net, photos, run.probes,
                                        random_lightings(rng, batch, run.augmentation_probes),
                                        run.log_specular_range)

        times = {"labeled_minibatch": [], "self_augmented_minibatch": [], "optimizer_step": []}
        run.optimize(0, run.maps.batch(rng, batch))  # warm-up: fills the probe bank's caches
        for index in range(1, repeats + 1):
            labeled, ms = milliseconds(lambda: run.maps.batch(rng, batch), device)
            times["labeled_minibatch"].append(ms)
            times["optimizer_step"].append(
                milliseconds(lambda: run.optimize(index, labeled), device)[1])
            augmented, ms = milliseconds(self_augmented, device)
            times["self_augmented_minibatch"].append(ms)
            run.optimize(index, augmented)
    median = {name: round(statistics.median(values), 1) for name, values in times.items()}
    labeled_step = median["labeled_minibatch"] + median["optimizer_step"]
    augmented_step = median["self_augmented_minibatch"] + median["optimizer_step"]
    print(json.dumps({"machine": f"{platform.machine()}, {os.cpu_count()} cores",
                      "torch_threads": torch.get_num_threads(), "device": device,
                      "network": network,
                      "input": config.input_size, "batch": batch, "median_ms": median,
                      "labeled_step_ms": round(labeled_step, 1),
                      "self_augmented_step_ms": round(augmented_step, 1),
                      "self_augmented_over_labeled": round(augmented_step / labeled_step, 3)},
                     indent=2))


if __name__ == "__main__":
    main()
