"""Renders one sa-estimate output folder twice, its Mitsuba scene (scene.xml, the reduced
SVBRDF with the Ward lobe) and its ``material.glb`` imported into Blender (Cycles, glTF's
metallic-roughness BRDF, scripts/blender_render_gltf.py), under the same probe and view, and
writes a figure Mitsuba | Blender | 4x difference, with the numbers as JSON on stdout.

Blender is Debian's (``apt-get install blender python3-numpy``, about 190 packages; not part of
``make setup``). Both images are exposed by the Mitsuba render's auto-exposure after the glTF
file's common albedo scale is undone (render/materials/gltf_file.py), so a difference in
overall brightness shows.

    .venv/bin/python scripts/compare_gltf_render.py ESTIMATE_FOLDER OUT.png [--spp 256]
"""

import json
import subprocess
import sys
import tempfile
from pathlib import Path

import click
import numpy as np
from PIL import Image

from render.common.color import REC709_LUMINANCE, to_png_bytes
from render.common.exposure import expose_numpy
from render.common.images import read_image
from render.materials.gltf_file import gltf_parameters
from render.materials.reduced_svbrdf import load_material
from render.mitsuba_reference.loading import load_mitsuba

BLENDER_SCRIPT = Path(__file__).resolve().parent / "blender_render_gltf.py"


@click.command()
@click.argument("folder", type=click.Path(exists=True, file_okay=False))
@click.argument("out", type=click.Path())
@click.option("--spp", default=256, show_default=True, help="Samples per pixel, both renderers.")
def main(folder, out, spp):
    folder = Path(folder)
    estimate = load_material(folder)
    height, width = estimate.albedo.shape[:2]
    mi = load_mitsuba()
    mitsuba = np.array(mi.render(mi.load_file(str(folder / "scene.xml"), spp=spp)), np.float32)
    with tempfile.TemporaryDirectory() as work:
        render = Path(work) / "blender.exr"
        result = subprocess.run(
            ["blender", "-b", "--factory-startup", "--python", str(BLENDER_SCRIPT), "--",
             str(folder / "material.glb"), str(folder / "mitsuba_probe.exr"), str(render),
             str(width), str(height), str(spp)], capture_output=True, text=True)
        if result.returncode != 0 or not render.is_file():
            sys.exit(f"Blender failed:\n{result.stdout[-2000:]}\n{result.stderr[-2000:]}")
        blender = read_image(render)[..., :3] * gltf_parameters(estimate)["scale"]
    exposed_mitsuba, exposure = expose_numpy(mitsuba)
    exposed_blender = np.clip(blender * exposure, 0.0, 1.0)
    difference = np.clip(4.0 * np.abs(exposed_blender - exposed_mitsuba), 0.0, 1.0)
    panels = [to_png_bytes(image) for image in (exposed_mitsuba, exposed_blender)]
    panels.append(np.round(difference * 255).astype(np.uint8))
    Image.fromarray(np.concatenate(panels, axis=1)).save(out)
    luminance = [float(np.mean(image @ np.array(REC709_LUMINANCE))) for image in (mitsuba,
                                                                                 blender)]
    rmse = float(np.sqrt(np.mean((exposed_blender - exposed_mitsuba) ** 2)))
    print(json.dumps({"folder": str(folder), "size": [width, height], "spp": spp,
                      "blender_over_mitsuba_mean_luminance": luminance[1] / luminance[0],
                      "rmse_exposed": rmse, "psnr_db": float(-20 * np.log10(max(rmse, 1e-12))),
                      "specular_albedo": estimate.specular.tolist(),
                      "roughness": estimate.roughness, "figure": out}))


if __name__ == "__main__":
    main()
