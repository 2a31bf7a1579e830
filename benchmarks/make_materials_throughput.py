"""Benchmark of make-materials: material sets per second per class, generated in memory and
written to disk (EXR maps and material.json), in one process. Prints JSON.

    python benchmarks/make_materials_throughput.py [--resolution 512] [--count 20]
"""

import json
import os
import platform
import tempfile
import time
from pathlib import Path

import click

from render.materials.procedural.material_set import GENERATORS, draw_metadata, regenerate
from render.materials.reduced_svbrdf import write_material


@click.command()
@click.option("--resolution", default=512, show_default=True, help="Map size (px).")
@click.option("--count", default=20, show_default=True, help="Sets per class.")
def main(resolution, count):
    results = {}
    with tempfile.TemporaryDirectory() as out:
        for material_class in sorted(GENERATORS):
            generate_seconds = write_seconds = 0.0
            for index in range(count):
                start = time.perf_counter()
                metadata = draw_metadata(material_class, 0, index, resolution)
                svbrdf = regenerate(metadata)
                middle = time.perf_counter()
                write_material(Path(out) / svbrdf.name, svbrdf, metadata)
                generate_seconds += middle - start
                write_seconds += time.perf_counter() - middle
            results[material_class] = {
                "generate_sets_per_second": round(count / generate_seconds, 2),
                "generate_and_write_sets_per_second":
                    round(count / (generate_seconds + write_seconds), 2)}
    print(json.dumps({"resolution": resolution, "count_per_class": count,
                      "machine": f"{platform.machine()}, {os.cpu_count()} cores",
                      "classes": results}, indent=2))


if __name__ == "__main__":
    main()
