"""Benchmark of SVBRDF-net inference: milliseconds per photo (network forward pass only, batch
of one, after warm-up) for the paper's, the compact (the shipped models: with a U-Net albedo
network, as wood and metal have, or a photo-affine one, as plastic has) and the small
configuration. Prints JSON.

    python benchmarks/estimate_speed.py [--device cpu|cuda] [--repeats 10]
"""

import dataclasses
import json
import os
import platform
import time

import click
import torch

from train.networks.svbrdf_net import COMPACT_CONFIG, SMALL_CPU_CONFIG, NetworkConfig, SVBRDFNet


def milliseconds(run, photo, repeats, device):
    """Mean milliseconds of ``run(photo)`` over ``repeats`` calls after one warm-up call."""
    with torch.no_grad():
        run(photo)
        if device.startswith("cuda"):
            torch.cuda.synchronize()
        start = time.perf_counter()
        for _ in range(repeats):
            run(photo)
        if device.startswith("cuda"):
            torch.cuda.synchronize()
    return round(1000 * (time.perf_counter() - start) / repeats, 2)


@click.command()
@click.option("--device", default="cpu", show_default=True)
@click.option("--repeats", default=10, show_default=True)
def main(device, repeats):
    results = {}
    photo_affine = dataclasses.replace(COMPACT_CONFIG, albedo_network="photo-affine")
    for name, config in (("paper", NetworkConfig()), ("compact", COMPACT_CONFIG),
                         ("compact, photo-affine albedo", photo_affine),
                         ("small", SMALL_CPU_CONFIG)):
        net = SVBRDFNet(config).to(device).eval()
        photo = torch.rand(1, 3, config.input_size, config.input_size, device=device)
        results[name] = {"input": config.input_size,
                         "ms_per_photo": milliseconds(net, photo, repeats, device)}
    print(json.dumps({"device": device, "machine": f"{platform.machine()}, {os.cpu_count()} cores",
                      "torch_threads": torch.get_num_threads(), "networks": results}, indent=2))


if __name__ == "__main__":
    main()
