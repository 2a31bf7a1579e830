"""A standalone Mitsuba scene file that renders one reduced SVBRDF under a probe.

It is ``scenes/planar_sample.xml`` with its defaults set for the material: the albedo and
normal textures (written beside it, flipped vertically as Mitsuba's texture v grows with world
+y, see render/mitsuba_reference/scene.py), the white-balanced probe (written beside it too),
the specular albedo, the roughness and the image size. Render it with the ``sa_ward`` plugin
registered::

    from render.mitsuba_reference.loading import load_mitsuba
    mi = load_mitsuba()
    image = mi.render(mi.load_file("scene.xml"))
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from render.common.atomic_files import atomic_path
from render.common.images import write_exr
from render.mitsuba_reference.scene import SCENE_FILE, matrix_text, probe_to_world

if TYPE_CHECKING:
    from render.common.probes import Probe

DEFAULT = re.compile(r'<default name="(\w+)" value="[^"]*"/>')


def write_scene_file(folder: str | Path, svbrdf: Any, probe: Probe, spp: int = 256) -> Path:
    """Write ``scene.xml``, its textures (``mitsuba_albedo.exr``, ``mitsuba_normal.exr``) and
    ``mitsuba_probe.exr`` (a render.common.probes.Probe's white-balanced radiance) into
    ``folder``; returns the scene file's path."""
    folder = Path(folder)
    height, width = svbrdf.albedo.shape[:2]
    write_exr(folder / "mitsuba_albedo.exr", np.flipud(svbrdf.albedo))
    write_exr(folder / "mitsuba_normal.exr", np.flipud(svbrdf.normal))
    write_exr(folder / "mitsuba_probe.exr", probe.radiance)
    values = {"spp": str(spp), "width": str(width), "height": str(height),
              "crop_width": str(width), "crop_height": str(height), "aspect": repr(height / width),
              "probe_to_world": matrix_text(probe_to_world(0.0)),
              "specular": " ".join(repr(float(v)) for v in svbrdf.specular),
              "alpha": repr(float(svbrdf.roughness))}
    text = DEFAULT.sub(lambda m: f'<default name="{m[1]}" value="{values.get(m[1], "")}"/>'
                       if m[1] in values else m[0], SCENE_FILE.read_text())
    files = {"albedo": "mitsuba_albedo.exr", "normal": "mitsuba_normal.exr",
             "probe": "mitsuba_probe.exr"}
    declarations = "".join(f'\n    <default name="{name}" value="{value}"/>'
                           for name, value in files.items())
    text = text.replace('<scene version="3.0.0">', '<scene version="3.0.0">' + declarations, 1)
    path = folder / "scene.xml"
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return path
