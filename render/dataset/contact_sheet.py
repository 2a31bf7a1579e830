"""A contact sheet of dataset samples for people to look at (PNG, sRGB).

Each row is one sample: the network input, the relative diffuse albedo, the normal map
(encoded as (n + 1) / 2) and a swatch of the relative specular albedo, labelled with the
material, probe, specular albedo and roughness.
"""

from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from render.common.atomic_files import atomic_path
from render.common.color import to_png_bytes

TILE = 128
LABEL_HEIGHT = 14


def _tile(pixels_8bit):
    return Image.fromarray(pixels_8bit).resize((TILE, TILE), Image.Resampling.BILINEAR)


def write_contact_sheet(path: str | Path, samples: list[dict]) -> None:
    """``samples``: list of dicts with image, albedo, normal (H, W, 3), log_specular (3,),
    log_roughness (1,) and provenance (dict)."""
    columns = 4
    sheet = Image.new("RGB", (columns * TILE, len(samples) * (TILE + LABEL_HEIGHT)), "white")
    draw = ImageDraw.Draw(sheet)
    for row, sample in enumerate(samples):
        top = row * (TILE + LABEL_HEIGHT)
        specular = np.exp(sample["log_specular"])
        normal_encoded = (np.asarray(sample["normal"], np.float32) + 1) / 2
        tiles = [to_png_bytes(np.asarray(sample["image"], np.float32)),
                 to_png_bytes(np.asarray(sample["albedo"], np.float32)),
                 np.round(normal_encoded * 255).astype(np.uint8),
                 to_png_bytes(np.broadcast_to(specular.astype(np.float32), (TILE, TILE, 3)))]
        for column, pixels in enumerate(tiles):
            sheet.paste(_tile(pixels), (column * TILE, top))
        info = sample["provenance"]
        label = (f"{info['material']} | {info['probe']} | rho_s/s "
                 f"{' '.join(f'{v:.3f}' for v in specular)} | alpha "
                 f"{float(np.exp(sample['log_roughness'][0])):.3f}")
        draw.text((2, top + TILE), label, fill="black")
    with atomic_path(path) as tmp:
        sheet.save(tmp, format="PNG")
