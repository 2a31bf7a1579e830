"""Recognizing which texture map a file is from the naming schemes people really use.

A file name's stem is lower-cased and split on ``_``, ``-``, ``.`` and spaces; trailing
resolution or variant tokens (``1k``, ``2048``, ``1``) are dropped; then the last two tokens,
and failing that the last one, are looked up below. ``fabric_pattern_07_nor_gl_1k.jpg`` is a
normal map (OpenGL), ``bricks_rgh.jpg`` a roughness map, ``texture_bricks.jpg`` nothing at all
(a folder whose only unrecognized image is such a file uses it as the albedo).
"""

import re
from pathlib import Path

ROLE_TOKENS = {
    "albedo": {"albedo", "alb", "col", "color", "colour", "basecolor", "basecolour", "base_color",
               "base_colour", "base_gray", "base_grey", "diffuse", "diff", "dif"},
    "normal": {"normal", "normals", "nrm", "nor", "norm", "nor_gl", "nor_dx", "normal_gl",
               "normal_dx", "nrm_gl", "nrm_dx", "normalgl", "normaldx"},
    "roughness": {"roughness", "rough", "rgh", "rou"},
    "glossiness": {"glossiness", "gloss"},
    "metallic": {"metallic", "metalness", "metal", "mtl", "met"},
    "arm": {"arm", "orm"},
    "ignored": {"ao", "occlusion", "ambientocclusion", "ambient_occlusion", "height", "disp",
                "displacement", "bump", "opacity", "alpha", "emission", "emissive", "cavity",
                "mask", "spec", "specular", "preview", "thumb", "thumbnail", "sss",
                "translucency", "transmission", "id"},
}
DIRECTX_TOKENS = {"nor_dx", "normal_dx", "nrm_dx", "normaldx"}
_TRAILING = re.compile(r"^(\d+k|\d+px|\d+)$")


def tokens(path: str | Path) -> list[str]:
    """Name tokens of a file, without trailing resolution/variant tokens."""
    parts = [t for t in re.split(r"[_\-.\s]+", Path(path).stem.lower()) if t]
    while len(parts) > 1 and _TRAILING.match(parts[-1]):
        parts.pop()
    return parts


def map_role(path: str | Path) -> str | None:
    """The role of a map file ('albedo', 'normal', ..., 'ignored') or None if unrecognized."""
    parts = tokens(path)
    candidates = ["_".join(parts[-2:])] if len(parts) >= 2 else []
    candidates.append(parts[-1] if parts else "")
    for candidate in candidates:
        for role, names in ROLE_TOKENS.items():
            if candidate in names:
                return role
    return None


def is_directx_normal(path: str | Path) -> bool:
    """True when the name marks a DirectX-style (green = down) normal map."""
    parts = tokens(path)
    return "_".join(parts[-2:]) in DIRECTX_TOKENS or (parts and parts[-1] in DIRECTX_TOKENS)
