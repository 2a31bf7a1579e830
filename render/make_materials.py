"""Command line of ``make-materials``: write procedural (or augmented) material sets of a class.

Each set is a material folder that ``render-dataset`` reads unchanged (render.materials
.write_material). Running the same command again skips the sets already written and makes the
missing ones; a folder written with other options is refused, never overwritten.
"""

import json
import logging
import time
from pathlib import Path

import click
from tqdm import tqdm

from render.errors import InputError
from render.exposure import expose
from render.material_sheet import write_material_sheet
from render.materials import find_materials, load_material, resample, write_material
from render.probes import load_probe
from render.procedural.augment import material_class_of
from render.procedural.material_set import GENERATORS, draw_metadata, regenerate, set_name

SHEET_ROWS = 8
SHEET_RENDER_SIZE = 256


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--class", "material_class", required=True, type=click.Choice(sorted(GENERATORS)),
              help="Material class to make.")
@click.option("--count", default=8, show_default=True, type=click.IntRange(min=1),
              help="Number of sets.")
@click.option("--out", required=True, type=click.Path(), help="Folder of material folders.")
@click.option("--seed", default=0, show_default=True, help="Seed of all random choices.")
@click.option("--resolution", default=512, show_default=True, type=click.IntRange(min=8),
              help="Map size (px, square).")
@click.option("--augment", "augment_folder", type=click.Path(), default=None,
              help="Make sets from the real sets of the class in this folder instead.")
@click.option("--probe", type=click.Path(), default=None,
              help="Also render the contact sheet's sets under this probe with Mitsuba.")
@click.option("--spp", default=128, show_default=True, type=click.IntRange(min=1),
              help="Samples per pixel of those renders.")
def main(material_class, count, out, seed, resolution, augment_folder, probe, spp):
    """Write COUNT material sets of one class, and a contact sheet of the first few."""
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    out = Path(out)
    try:
        sources = None if augment_folder is None else _real_sets(augment_folder, material_class)
        probe = None if probe is None else load_probe(probe)  # checked before any work
        start = time.perf_counter()
        written, kept, sheet_sets = 0, 0, []
        for index in tqdm(range(count), desc=f"{material_class} sets", unit="set"):
            metadata = draw_metadata(material_class, seed, index, resolution, sources)
            folder = out / set_name(material_class, seed, index, sources is not None)
            if folder.exists():
                _check_same(folder, metadata)
                kept += 1
                svbrdf = load_material(folder) if index < SHEET_ROWS else None
            else:
                svbrdf = regenerate(metadata, sources)
                write_material(folder, svbrdf, metadata)
                written += 1
            if index < SHEET_ROWS:
                sheet_sets.append(svbrdf)
        seconds = time.perf_counter() - start
        sheet = out / f"contact_sheet_{material_class}.png"
        renders = None if probe is None else _renders(sheet_sets, probe, spp)
        write_material_sheet(sheet, sheet_sets, renders)
    except (InputError, ValueError) as error:
        raise click.ClickException(str(error)) from None
    click.echo(json.dumps({"class": material_class, "written": written, "already_there": kept,
                           "seconds": round(seconds, 3),
                           "sets_per_second": round(written / seconds, 3) if written else None,
                           "contact_sheet": str(sheet)}))


def _real_sets(folder, material_class):
    """The real sets of the class in ``folder``, by name."""
    sets = {}
    for path in find_materials(folder):
        svbrdf = load_material(path)
        if material_class_of(svbrdf) == material_class:
            sets[svbrdf.name] = svbrdf
    if not sets:
        raise InputError(folder, f"no {material_class} set (a material.json 'class' or a "
                                 f"{material_class} word in the folder name marks one)")
    return sets


def _check_same(folder, metadata):
    """Refuse an existing set folder made with other options."""
    path = folder / "material.json"
    try:
        existing = json.loads(path.read_text()).get("metadata")
    except (OSError, json.JSONDecodeError):
        existing = None
    if existing != json.loads(json.dumps(metadata)):
        raise InputError(folder, "exists but was made with other options; use another --out")


def _renders(svbrdfs, probe, spp):
    """Each set under the probe, through the Mitsuba pipeline, exposed like a dataset sample."""
    from render.scene import PlanarSampleRenderer  # loads Mitsuba: only when rendering

    renderer = PlanarSampleRenderer(spp=spp)
    renders = []
    for svbrdf in tqdm(svbrdfs, desc="contact sheet renders", unit="render"):
        small = resample(svbrdf, min(SHEET_RENDER_SIZE, svbrdf.albedo.shape[0]))
        renders.append(expose(renderer.render(small, probe))[0])
    return renders


if __name__ == "__main__":
    main()
