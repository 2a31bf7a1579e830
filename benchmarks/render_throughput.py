"""Benchmark of render-dataset's Mitsuba renders: images per second at 256x256 at a given
sample count, and how converged those images are (PSNR against a render with 16 times the
samples, on the auto-exposed, clamped [0, 1] images). Prints JSON.

    python benchmarks/render_throughput.py [--spp 1024] [--pairs 4] [--shared] \
        [--variant llvm_ad_rgb|cuda_ad_rgb] [--save IMAGES.npz] [--compare-to IMAGES.npz]

``--save`` keeps the timed renders (HDR radiance), and ``--compare-to`` reports the PSNR of the
timed renders against such a file's (the same cases: same options but the variant), so that
two variants' renders can be compared (benchmarks/gpu_figures.py).

With --shared, materials and probes come from ../shared/data (the hardest probes, with the
sun, included); otherwise from the bundled ones.
"""

import json
import platform
import time
from pathlib import Path

import click
import numpy as np

from render.common.atomic_files import write_npz
from render.common.exposure import exposure_scale
from render.common.probes import find_probes, load_probe
from render.materials.reduced_svbrdf import find_materials, load_material, resample
from render.mitsuba_reference.scene import PlanarSampleRenderer

REPO = Path(__file__).resolve().parent.parent
SHARED = REPO.parent / "shared" / "data"


def psnr(image, reference, key):
    scale = exposure_scale(reference, key)
    a, b = (np.clip(x * scale, 0, 1) for x in (image, reference))
    return float(10 * np.log10(1.0 / max(np.mean((a - b) ** 2), 1e-20)))


@click.command()
@click.option("--spp", default=1024, show_default=True)
@click.option("--size", default=256, show_default=True)
@click.option("--pairs", default=4, show_default=True, help="(material, probe) pairs to time.")
@click.option("--sampler", default="multijitter", show_default=True)
@click.option("--shared", is_flag=True, help="Use ../shared/data instead of bundled data.")
@click.option("--reference/--no-reference", default=True, show_default=True,
              help="Also render the 16x reference and report PSNR (slow).")
@click.option("--variant", default="llvm_ad_rgb", show_default=True, help="Mitsuba variant.")
@click.option("--save", type=click.Path(), default=None, help="Write the timed renders here.")
@click.option("--compare-to", type=click.Path(exists=True, dir_okay=False), default=None,
              help="Renders of the same cases (--save of another run) to compare with.")
def main(spp, size, pairs, sampler, shared, reference, variant, save, compare_to):
    root = SHARED if shared else None
    materials = find_materials(root / "svbrdfs" if root else REPO / "scenes" / "materials")
    probes = find_probes(root / "probes" if root else REPO / "probes")
    rng = np.random.default_rng(0)
    renderer = PlanarSampleRenderer(variant, spp=spp, sampler=sampler)
    renderer.mi.set_log_level(renderer.mi.LogLevel.Error)  # warnings would go to stdout, into the JSON
    warm_up = resample(load_material(materials[0]), size)  # compiles the kernels of this size
    renderer.render(type(warm_up)(warm_up.name, warm_up.albedo[:size, :size],
                                  warm_up.normal[:size, :size], warm_up.specular,
                                  warm_up.roughness), load_probe(probes[0]))
    cases, images = [], []
    for i in range(pairs):
        material = resample(load_material(materials[i % len(materials)]), size)
        material = type(material)(material.name, material.albedo[:size, :size],
                                  material.normal[:size, :size], material.specular,
                                  material.roughness, material.sources)
        probe = load_probe(probes[int(rng.integers(len(probes)))])
        rotation = float(rng.uniform(0, 360))
        start = time.perf_counter()
        image = renderer.render(material, probe, rotation, seed=1)
        seconds = time.perf_counter() - start
        cases.append({"material": material.name, "probe": probe.name, "seconds": seconds})
        images.append(np.asarray(image, np.float32))
        if reference:
            truth = renderer.render(material, probe, rotation, seed=2, spp=16 * spp)
            cases[-1]["psnr_db_vs_16x"] = psnr(image, truth, 0.18)
    if save:
        write_npz(save, images=np.stack(images))
    if compare_to:
        with np.load(compare_to) as other:
            for case, image, theirs in zip(cases, images, other["images"], strict=True):
                case["psnr_db_vs_compared"] = psnr(image, theirs, 0.18)
    total = sum(c["seconds"] for c in cases)
    print(json.dumps({
        "benchmark": "render_throughput", "machine": platform.processor() or platform.machine(),
        "variant": variant, "size": size, "spp": spp, "sampler": sampler,
        "images_per_second": len(cases) / total,
        **({"min_psnr_db_vs_16x": min(c["psnr_db_vs_16x"] for c in cases),
            "mean_psnr_db_vs_16x": float(np.mean([c["psnr_db_vs_16x"] for c in cases]))}
           if reference else {}),
        **({"min_psnr_db_vs_compared": min(c["psnr_db_vs_compared"] for c in cases)}
           if compare_to else {}),
        "cases": cases}, indent=2))


if __name__ == "__main__":
    main()
