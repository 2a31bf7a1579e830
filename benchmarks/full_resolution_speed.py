"""Benchmark of full-resolution maps (train.estimation.full_resolution) with the shipped metal
model (a U-Net albedo network, which runs in tiles): seconds per photo for a 1024x1024 and a 2048x1536 photo (the bundled photo resized, so
the network sees texture), and the process's peak resident memory. Prints JSON.

    python benchmarks/full_resolution_speed.py [--device cpu|cuda] [--repeats 2]
"""

import json
import os
import platform
import resource
import time
from pathlib import Path

import click
import torch

from render.common.images import resize
from train.data.photos import read_linear_photo
from train.estimation.full_resolution import TILE_OVERLAP, full_resolution_maps
from train.networks.model_files import load_network, shipped_model_path

PHOTO = Path(__file__).resolve().parent.parent / "scenes" / "photos" / "brick-reference-01.jpg"


@click.command()
@click.option("--device", default="cpu", show_default=True)
@click.option("--repeats", default=2, show_default=True)
def main(device, repeats):
    net = load_network(shipped_model_path("metal"), torch.device(device))
    base = read_linear_photo(PHOTO)
    results = []
    for width, height in ((1024, 1024), (2048, 1536)):
        photo = resize(base, height, width)
        full_resolution_maps(net, photo[:256, :256])  # warm-up
        start = time.perf_counter()
        for _ in range(repeats):
            albedo, _ = full_resolution_maps(net, photo)
        seconds = (time.perf_counter() - start) / repeats
        results.append({"photo": f"{width}x{height}", "maps": list(albedo.shape[1::-1]),
                        "seconds": round(seconds, 2),
                        "megapixels_per_second": round(width * height / 1e6 / seconds, 3)})
    peak_mib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(json.dumps({"device": device, "machine": f"{platform.machine()}, {os.cpu_count()} cores",
                      "torch_threads": torch.get_num_threads(), "model": "metal (compact)",
                      "tile": net.config.input_size, "overlap": TILE_OVERLAP,
                      "results": results, "peak_resident_mib": round(peak_mib)}, indent=2))


if __name__ == "__main__":
    main()
