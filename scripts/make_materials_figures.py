"""The figures of docs/make-materials.md: a contact sheet per class and the parameter plot.

    .venv/bin/python scripts/make_materials_figures.py --shared ../shared/data \
        --out docs/make-materials

Contact sheets: ``make-materials --class C --count ROWS --resolution 512 --probe PROBE``, each
set rendered through the Mitsuba pipeline; the real sets of the shared data get a sheet too, so
the look can be compared. The plot shows the homogeneous specular albedo (luminance) and Ward
roughness of SAMPLES generated sets per class, next to the real sets and the measured materials
of the bundled database (with the reduction of docs/conventions.md: metals' F0 is their color,
dielectrics' F0 follows from the index of refraction, alpha = r^2 clamped to [0.02, 1]).
"""

import shutil
import subprocess
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import click
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

from render.common.color import luminance  # noqa: E402
from render.common.exposure import expose_numpy  # noqa: E402
from render.common.probes import load_probe  # noqa: E402
from render.materials.material_sheet import write_material_sheet  # noqa: E402
from render.materials.procedural.augment import material_class_of  # noqa: E402
from render.materials.procedural.material_set import (GENERATORS, draw_metadata,  # noqa: E402
                                                      regenerate)
from render.materials.procedural.palette import measured_materials  # noqa: E402
from render.materials.reduced_svbrdf import (ALPHA_RANGE, find_materials,  # noqa: E402
                                             load_material, resample)
from render.mitsuba_reference.scene import PlanarSampleRenderer  # noqa: E402

CLASS_COLORS = {"wood": "tab:brown", "plastic": "tab:blue", "metal": "tab:gray"}


@click.command()
@click.option("--shared", required=True, type=click.Path(exists=True), help="../shared/data")
@click.option("--out", required=True, type=click.Path(), help="Folder of the figures.")
@click.option("--probe", default="hilly_terrain_01", show_default=True,
              help="Shared probe (stem) of the contact sheet renders.")
@click.option("--rows", default=8, show_default=True, help="Sets per contact sheet.")
@click.option("--samples", default=200, show_default=True, help="Generated sets per class.")
@click.option("--spp", default=256, show_default=True, help="Samples per pixel of the renders.")
def main(shared, out, probe, rows, samples, spp):
    shared, out = Path(shared), Path(out)
    out.mkdir(parents=True, exist_ok=True)
    probe_path = shared / "probes" / f"{probe}.exr"
    with tempfile.TemporaryDirectory() as maps:
        for material_class in sorted(GENERATORS):
            subprocess.run([str(Path(sys.executable).with_name("make-materials")), "--class",
                            material_class, "--count", str(rows), "--resolution", "512",
                            "--out", maps, "--probe", str(probe_path), "--spp", str(spp)],
                           check=True)
            shutil.copy(Path(maps) / f"contact_sheet_{material_class}.png",
                        out / f"contact_sheet_{material_class}.png")
    real = [load_material(path) for path in find_materials(shared / "svbrdfs")]
    _real_sheet(out / "contact_sheet_real_sets.png", real, load_probe(probe_path), spp)
    _parameter_plot(out / "parameter_distributions.png", real, samples)


def _real_sheet(path, real, probe, spp):
    renderer = PlanarSampleRenderer(spp=spp)
    squares = [replace(small, albedo=small.albedo[:256, :256], normal=small.normal[:256, :256])
               for small in (resample(svbrdf, 256) for svbrdf in real)]
    renders = [expose_numpy(renderer.render(s, probe))[0] for s in tqdm(squares, desc="real sets")]
    write_material_sheet(path, squares, renders)


def _parameter_plot(path, real, samples):
    groups = {}
    for material_class in sorted(GENERATORS):
        values = []
        for index in tqdm(range(samples), desc=f"{material_class} parameters"):
            svbrdf = regenerate(draw_metadata(material_class, 0, index, 48))
            values.append((float(luminance(svbrdf.specular)), svbrdf.roughness))
        groups[f"generated {material_class}"] = (values, CLASS_COLORS[material_class])
    for material_class in sorted(GENERATORS):
        values = [(float(luminance(s.specular)), s.roughness) for s in real
                  if material_class_of(s) == material_class]
        groups[f"real sets: {material_class} ({len(values)})"] = (values, "black")
    others = [(float(luminance(s.specular)), s.roughness) for s in real
              if material_class_of(s) is None]
    groups[f"real sets: other ({len(others)})"] = (others, "black")
    database = {"Metal": [], "Plastic": [], "other dielectrics": []}
    for material in measured_materials():
        key = material.category if material.category in ("Metal", "Plastic") else \
            "other dielectrics"
        alpha = float(np.clip(material.roughness ** 2, *ALPHA_RANGE))
        database[key].append((float(luminance(np.array(material.specular, np.float32))), alpha))
    for key, values in database.items():
        groups[f"measured: {key} ({len(values)})"] = (values, "tab:red")

    figure, axes = plt.subplots(1, 2, figsize=(12, 5.5), sharey=True)
    rng = np.random.default_rng(0)
    for row, (label, (values, color)) in enumerate(groups.items()):
        values = np.asarray(values).reshape(-1, 2)
        jitter = row + rng.uniform(-0.25, 0.25, len(values))
        for axis, column in zip(axes, (0, 1)):
            axis.scatter(values[:, column], jitter, s=8, alpha=0.5, color=color)
    axes[0].set_yticks(range(len(groups)), list(groups))
    axes[0].invert_yaxis()
    axes[0].set_xscale("log")
    axes[0].set_xlabel("specular albedo rho_s (luminance)")
    axes[1].set_xscale("log")
    axes[1].set_xlabel("Ward roughness alpha (polished, r = 0, shows as 0.02)")
    for axis in axes:
        axis.grid(True, which="both", alpha=0.3)
    figure.suptitle("Homogeneous parameters: generated sets, real sets, measured materials")
    figure.tight_layout()
    figure.savefig(path, dpi=110)


if __name__ == "__main__":
    main()
