"""Where the time of one render-dataset Mitsuba render goes, per phase. Prints JSON.

    python benchmarks/render_profile.py [--spp 1024] [--size 256] [--shared]

Phases of PlanarSampleRenderer.render for one 256x256 image (a material and probe of the
bundled or shared data), each timed on its own:
- texture files: writing the albedo, normal and probe EXR files Mitsuba loads;
- scene build: ``mi.load_file`` (XML parse, textures and the probe's sampling tables);
- first render of a new scene: tracing the Python BSDF, compiling the kernel, running it;
- the same scene rendered again with another seed (is the kernel reused?);
- a strip's render (the lane budget splits a 1024 spp image into strips);
- exposure and writing the sample (numpy, EXR).
Dr.Jit's kernel-cache counters are read before and after each phase where available.
"""

import json
import platform
import tempfile
import time
from pathlib import Path

import click
import numpy as np

from render.common.exposure import expose_numpy
from render.common.images import write_exr
from render.common.probes import find_probes, load_probe
from render.materials.reduced_svbrdf import find_materials, load_material, resample
from render.mitsuba_reference.scene import (SCENE_FILE, PlanarSampleRenderer, camera_to_world,
                                            matrix_text, probe_to_world)

REPO = Path(__file__).resolve().parent.parent
SHARED = REPO.parent / "shared" / "data"


def timed(function):
    start = time.perf_counter()
    result = function()
    return result, round(time.perf_counter() - start, 3)


@click.command()
@click.option("--spp", default=1024, show_default=True)
@click.option("--size", default=256, show_default=True)
@click.option("--shared", is_flag=True, help="Use ../shared/data instead of bundled data.")
def main(spp, size, shared):
    root = SHARED if shared else None
    material = resample(load_material(find_materials(
        root / "svbrdfs" if root else REPO / "scenes" / "materials")[0]), size)
    material = type(material)(material.name, material.albedo[:size, :size],
                              material.normal[:size, :size], material.specular,
                              material.roughness)
    probe = load_probe(find_probes(root / "probes" if root else REPO / "probes")[0])
    renderer = PlanarSampleRenderer("llvm_ad_rgb", spp=spp)
    renderer.mi.set_log_level(renderer.mi.LogLevel.Error)  # warnings would go to stdout, into the JSON
    mi = renderer.mi
    phases = {}
    with tempfile.TemporaryDirectory() as work:
        files = {}

        def write_textures():
            for name, pixels in (("albedo", np.flipud(material.albedo)),
                                 ("normal", np.flipud(material.normal)),
                                 ("probe", probe.radiance)):
                files[name] = str(Path(work) / f"{name}.exr")
                write_exr(files[name], pixels)

        _, phases["texture_files_s"] = timed(write_textures)
        rows = min(size // 2, max(1, renderer.lane_budget // (size * spp)))
        params = dict(spp=str(spp), sampler=renderer.sampler, width=str(size),
                      height=str(size), crop_x="0", crop_width=str(size), aspect="1.0",
                      camera=matrix_text(camera_to_world((0.0, 0.0, 1.0))),
                      probe_to_world=matrix_text(probe_to_world(30.0)),
                      specular=" ".join(repr(float(v)) for v in material.specular),
                      alpha=repr(float(material.roughness)), **files)
        scene, phases["scene_build_s"] = timed(lambda: mi.load_file(
            str(SCENE_FILE), crop_y="0", crop_height=str(rows), **params))
        _, phases["first_render_of_new_scene_s"] = timed(
            lambda: np.array(mi.render(scene, seed=0)))
        _, phases["same_scene_new_seed_s"] = timed(lambda: np.array(mi.render(scene, seed=1)))
        scene2, phases["second_scene_build_s"] = timed(lambda: mi.load_file(
            str(SCENE_FILE), crop_y=str(rows), crop_height=str(rows), **params))
        _, phases["second_scene_first_render_s"] = timed(
            lambda: np.array(mi.render(scene2, seed=2)))
        phases["strip_rows"] = rows
        phases["strips_per_image"] = -(-size // rows)
        image, phases["whole_image_s"] = timed(lambda: renderer.render(material, probe, 30.0))
        _, phases["exposure_s"] = timed(lambda: expose_numpy(image))
        _, phases["write_exr_s"] = timed(lambda: write_exr(Path(work) / "sample.exr", image))
    print(json.dumps({"benchmark": "render_profile",
                      "machine": platform.processor() or platform.machine(),
                      "size": size, "spp": spp, "material": material.name, "probe": probe.name,
                      "phases": phases}, indent=2))


if __name__ == "__main__":
    main()
