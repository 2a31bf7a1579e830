"""Benchmark of the torch renderer: images per second for a batch at 256x256, and the speed-up
over Mitsuba rendering the same images to the same error, in the same run. Prints JSON.

    python benchmarks/torch_renderer_throughput.py [--batch 16] [--size 256] [--shared]
        [--device cpu|cuda] [--compare 4] [--reference-spp 4096] [--roughness ALPHA]
        [--backward]

The batch draws materials, probes, rotations and roughness (log-uniform in [0.02, 1], or the
one given) at random. For the first ``--compare`` images, a Mitsuba render at
``--reference-spp`` is the reference; the torch error is the worst PSNR (exposed, clamped
images) against it. Mitsuba then renders the same images at 16, 32, 64, ... spp until its worst
PSNR against the same reference reaches the torch one; its time per image at that count is
compared with the torch time per image. With ``--backward`` the timed work is a render and its
backward pass, with gradients in the four maps (a training loss's use), and nothing is
compared.
"""

import dataclasses
import json
import platform
import time
from pathlib import Path

import click
import numpy as np
import torch

from render.common.exposure import expose_numpy
from render.common.probes import find_probes, load_probe
from render.materials.reduced_svbrdf import find_materials, load_material
from render.torch_renderer.check import psnr, square_crop
from render.torch_renderer.renderer import ProbeBank, render

REPO = Path(__file__).resolve().parent.parent
SHARED = REPO.parent / "shared" / "data"


def worst_psnr(images, references):
    return min(psnr(expose_numpy(a)[0], expose_numpy(b)[0]) for a, b in zip(images, references))


@click.command()
@click.option("--batch", default=16, show_default=True)
@click.option("--size", default=256, show_default=True)
@click.option("--repeats", default=5, show_default=True, help="Timed batches (median kept).")
@click.option("--device", default="cpu", show_default=True)
@click.option("--compare", default=4, show_default=True,
              help="Images also rendered with Mitsuba (0: no comparison).")
@click.option("--reference-spp", default=4096, show_default=True)
@click.option("--shared", is_flag=True, help="Use ../shared/data instead of bundled data.")
@click.option("--seed", default=0, show_default=True)
@click.option("--roughness", type=float, default=None,
              help="One Ward alpha for the whole batch (time per roughness); default: random.")
@click.option("--backward", is_flag=True,
              help="Time a render and its backward pass (gradients in the maps) instead.")
def main(batch, size, repeats, device, compare, reference_spp, shared, seed, roughness,
         backward):
    fixed = roughness
    probe_dir, material_dir = ((SHARED / "probes", SHARED / "svbrdfs") if shared
                               else (REPO / "probes", REPO / "scenes" / "materials"))
    probes = [load_probe(p) for p in find_probes(probe_dir)]
    materials = [load_material(m) for m in find_materials(material_dir)]
    rng = np.random.default_rng(seed)
    chosen = rng.integers(0, len(materials), batch)
    maps = [square_crop(materials[i], size) for i in chosen]
    probe_index = rng.integers(0, len(probes), batch)
    rotation = rng.uniform(0, 360, batch)
    roughness = (np.exp(rng.uniform(np.log(0.02), 0, batch)) if roughness is None
                 else np.full(batch, roughness))
    specular = np.stack([materials[i].specular for i in chosen])

    bank = ProbeBank([p.radiance for p in probes], device=device)
    inputs = dict(
        albedo=torch.from_numpy(np.stack([m[0] for m in maps])).permute(0, 3, 1, 2).to(device),
        normal=torch.from_numpy(np.stack([m[1] for m in maps])).permute(0, 3, 1, 2).to(device),
        specular=torch.tensor(specular, dtype=torch.float32, device=device),
        roughness=torch.tensor(roughness, dtype=torch.float32, device=device),
        probes=bank, probe_index=torch.tensor(probe_index, device=device),
        rotation_deg=torch.tensor(rotation, dtype=torch.float32, device=device))
    differentiated = ("albedo", "normal", "specular", "roughness")

    def timed_render():
        if backward:
            for name in differentiated:
                inputs[name] = inputs[name].detach().requires_grad_()
        if device.startswith("cuda"):
            torch.cuda.synchronize()
        started = time.perf_counter()
        images = render(**inputs)
        if backward:
            images.sum().backward()
        if device.startswith("cuda"):
            torch.cuda.synchronize()
        return images.detach(), time.perf_counter() - started

    with torch.set_grad_enabled(backward):
        timed_render()  # warm-up: fills the probe bank's caches
        images, seconds = None, []
        for _ in range(repeats):
            images, elapsed = timed_render()
            seconds.append(elapsed)
    torch_seconds = float(np.median(seconds))
    result = dict(machine=platform.processor() or platform.machine(), device=device,
                  torch_threads=torch.get_num_threads(), batch=batch, size=size,
                  data="shared" if shared else "bundled",
                  roughness="log-uniform [0.02, 1]" if fixed is None else fixed,
                  timed="render and backward pass" if backward else "render",
                  torch_seconds_per_batch=round(torch_seconds, 4),
                  torch_images_per_second=round(batch / torch_seconds, 2))

    if compare and not backward:
        from render.mitsuba_reference.scene import PlanarSampleRenderer

        ours = images[:compare].permute(0, 2, 3, 1).cpu().numpy()
        mitsuba = PlanarSampleRenderer(spp=reference_spp)
        svbrdfs = [dataclasses.replace(materials[i], albedo=maps[k][0], normal=maps[k][1],
                                       roughness=float(roughness[k]))
                   for k, i in enumerate(chosen[:compare])]

        def mitsuba_render(spp, seed_offset):
            started = time.perf_counter()
            out = [mitsuba.render(s, probes[probe_index[k]], rotation[k], seed=seed_offset + k,
                                  spp=spp) for k, s in enumerate(svbrdfs)]
            return out, (time.perf_counter() - started) / len(svbrdfs)

        references, _ = mitsuba_render(reference_spp, 0)
        torch_psnr = worst_psnr(ours, references)
        spp, matched = 16, None
        while spp < reference_spp:
            renders, per_image = mitsuba_render(spp, 1000)
            mitsuba_psnr = worst_psnr(renders, references)
            matched = dict(spp=spp, worst_psnr_db=round(mitsuba_psnr, 2),
                           seconds_per_image=round(per_image, 4))
            if mitsuba_psnr >= torch_psnr:
                break
            spp *= 2
        result.update(
            compared_images=compare, reference_spp=reference_spp,
            torch_worst_psnr_db=round(torch_psnr, 2), mitsuba_same_error=matched,
            speedup_same_error=round(matched["seconds_per_image"] / (torch_seconds / batch), 1),
            mitsuba_same_error_reached=matched["worst_psnr_db"] >= torch_psnr)
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
