"""A contact sheet of material sets for people to judge (PNG, sRGB).

Each row is one set: its diffuse albedo (scaled to mean 0.5, as the network's relative albedo),
its normal map (encoded (n + 1) / 2), a swatch of its specular albedo rho_s and, when given, a
render under a probe (auto-exposed, clamped), labelled with the name, specular albedo and Ward
roughness.
"""

from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from render.common.atomic_files import atomic_path
from render.common.color import normal_to_png_bytes, to_png_bytes
from render.common.labels import relative_labels
from render.materials.reduced_svbrdf import ReducedSVBRDF

TILE = 160
LABEL_HEIGHT = 14


def write_material_sheet(path: str | Path, svbrdfs: list[ReducedSVBRDF],
                         renders: list[np.ndarray] | None = None) -> None:
    """``svbrdfs``: ReducedSVBRDFs; ``renders``: matching exposed LDR images, or None."""
    columns = 3 if renders is None else 4
    sheet = Image.new("RGB", (columns * TILE, len(svbrdfs) * (TILE + LABEL_HEIGHT)), "white")
    draw = ImageDraw.Draw(sheet)
    for row, svbrdf in enumerate(svbrdfs):
        top = row * (TILE + LABEL_HEIGHT)
        albedo, _ = relative_labels(svbrdf.albedo, svbrdf.specular)
        swatch = np.broadcast_to(svbrdf.specular.astype(np.float32), (TILE, TILE, 3))
        tiles = [to_png_bytes(albedo), normal_to_png_bytes(svbrdf.normal), to_png_bytes(swatch)]
        if renders is not None:
            tiles.append(to_png_bytes(renders[row]))
        for column, pixels in enumerate(tiles):
            tile = Image.fromarray(pixels).resize((TILE, TILE), Image.Resampling.BOX)
            sheet.paste(tile, (column * TILE, top))
        specular = " ".join(f"{v:.3f}" for v in svbrdf.specular)
        draw.text((2, top + TILE), f"{svbrdf.name} | rho_s {specular} | alpha "
                                   f"{svbrdf.roughness:.3f}", fill="black")
    with atomic_path(path) as tmp:
        sheet.save(tmp, format="PNG")
