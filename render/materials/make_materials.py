"""``make-materials``: write procedural (or augmented) material sets of a class.

Each set is a material folder that ``render-dataset`` reads unchanged
(render.materials.reduced_svbrdf.write_material). Running the same command again skips the
sets already written and makes the missing ones; a folder written with other options is
refused, never overwritten.
"""

import json
import time
from dataclasses import dataclass

from tqdm import tqdm

from render.common.errors import InputError, require_output_folder
from render.common.exposure import expose_numpy
from render.common.probes import load_probe
from render.common.resume import differing_options
from render.materials.material_sheet import write_material_sheet
from render.materials.procedural.augment import material_class_of
from render.materials.procedural.material_set import draw_metadata, regenerate, set_name
from render.materials.reduced_svbrdf import find_materials, load_material, resample, write_material

SHEET_ROWS = 8
SHEET_RENDER_SIZE = 256


@dataclass(frozen=True)
class MakeMaterialsConfig:
    material_class: str
    """Material class to make: wood, plastic or metal (render.materials.procedural.material_set
    .GENERATORS)."""
    out: str
    """Folder of material folders; the sets already in it are kept, not made again."""
    count: int = 8
    """Number of sets."""
    seed: int = 0
    """Seed of all random choices."""
    resolution: int = 512
    """Map size (px, square)."""
    augment: str | None = None
    """None: procedural sets. Otherwise a folder of real sets: make sets from those of the
    class instead."""
    probe: str | None = None
    """Also render the contact sheet's sets under this probe with Mitsuba (None: no renders)."""
    spp: int = 128
    """Samples per pixel of those renders."""


def run(cfg: MakeMaterialsConfig) -> dict:
    """Write the sets of ``cfg`` that are not there yet and a contact sheet of the first few;
    returns a summary (counts, time, the contact sheet's path)."""
    out = require_output_folder(cfg.out)
    sources = None if cfg.augment is None else _real_sets(cfg.augment, cfg.material_class)
    probe = None if cfg.probe is None else load_probe(cfg.probe)  # checked before any work
    start = time.perf_counter()
    written, kept, sheet_sets = 0, 0, []
    for index in tqdm(range(cfg.count), desc=f"{cfg.material_class} sets", unit="set"):
        metadata = draw_metadata(cfg.material_class, cfg.seed, index, cfg.resolution, sources)
        folder = out / set_name(cfg.material_class, cfg.seed, index, sources is not None)
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
    sheet = out / f"contact_sheet_{cfg.material_class}.png"
    renders = None if probe is None else _renders(sheet_sets, probe, cfg.spp)
    write_material_sheet(sheet, sheet_sets, renders)
    return {"class": cfg.material_class, "written": written, "already_there": kept,
            "seconds": round(seconds, 3),
            "sets_per_second": round(written / seconds, 3) if written else None,
            "contact_sheet": str(sheet)}


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
    if not isinstance(existing, dict):
        raise InputError(folder, "exists but is not a set of make-materials; use another --out")
    differing = differing_options(existing, metadata, may_change=())
    if differing:
        raise InputError(folder, f"exists but was made with other options (differing: "
                                 f"{', '.join(differing)}); use another --out")


def _renders(svbrdfs, probe, spp):
    """Each set under the probe, through the Mitsuba pipeline, exposed like a dataset sample."""
    from render.mitsuba_reference.scene import PlanarSampleRenderer  # loads Mitsuba: only here

    renderer = PlanarSampleRenderer(spp=spp)
    renders = []
    for svbrdf in tqdm(svbrdfs, desc="contact sheet renders", unit="render"):
        small = resample(svbrdf, min(SHEET_RENDER_SIZE, svbrdf.albedo.shape[0]))
        renders.append(expose_numpy(renderer.render(small, probe))[0])
    return renders

