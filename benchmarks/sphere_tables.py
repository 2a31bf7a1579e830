"""Benchmark of sa-validate's sphere tables (train.brdf_validation.validation.SphereRenderer): seconds to
render the diffuse and specular images of a configuration's lightings. Prints JSON.

    python benchmarks/sphere_tables.py [--config small] [--levels 29] [--probes probes]

``--levels`` roughness levels log-uniform in [0.02, 1] (the small configuration tabulates 29);
the lightings are those of seed 0, as ``sa-validate --config CONFIG`` draws them.
"""

import json
import os
import platform
import time
from pathlib import Path

import click
import torch

from render.common.probes import find_probes
from train.brdf_validation.validation import CONFIGURATIONS, ValidationConfig, make_renderer

REPO = Path(__file__).resolve().parent.parent


@click.command()
@click.option("--config", "configuration", type=click.Choice(list(CONFIGURATIONS)),
              default="small", show_default=True)
@click.option("--levels", default=29, show_default=True)
@click.option("--probes", default=str(REPO / "probes"), show_default=True)
def main(configuration, levels, probes):
    cfg = ValidationConfig(probes=probes, out="", **(CONFIGURATIONS[configuration]
                                                     | {"alpha_levels": levels}))
    start = time.perf_counter()
    make_renderer(cfg)
    seconds = time.perf_counter() - start
    print(json.dumps({"machine": f"{platform.machine()}, {os.cpu_count()} cores",
                      "torch_threads": torch.get_num_threads(), "config": configuration,
                      "size": cfg.size, "lightings": cfg.lightings,
                      "probes": len(find_probes(probes)), "levels": levels, "seconds": round(seconds, 2)}))


if __name__ == "__main__":
    main()
